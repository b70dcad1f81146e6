// The vehicle map kind `octomap`: OctoMap's probabilistic sensor model (log-odds per voxel,
// clamped), the tree updated with every frame.
#include <octomap/OcTree.h>

#include <optional>

#include "kinolab/core/fields.hpp"
#include "kinolab/core/plugin.hpp"
#include "kinolab/flight/vehicle_map.hpp"

namespace kinolab {
namespace {

/// OctoMap's sensor model.
struct OctomapModel {
  double probability_hit = 0.7;
  double probability_miss = 0.4;

  template <typename Fields>
  void fields(Fields& f) {
    f.real("probability_hit", probability_hit, 0.51, 0.99,
           "the probability a hit gives its voxel (OctoMap's prob_hit)");
    f.real("probability_miss", probability_miss, 0.01, 0.49,
           "the probability a ray passing through gives a voxel (prob_miss)");
  }
};

class OctomapVehicleMap final : public VehicleMap {
 public:
  explicit OctomapVehicleMap(const OctomapModel& model) : sensor_model_(model) {}

 protected:
  // The tree holds positions relative to the map's origin (the lattice's minimum corner), so
  // that its voxels [k r, (k + 1) r) are exactly the lattice's voxels.
  void doSetup() override {
    tree_.emplace(model().resolution);
    tree_->setProbHit(sensor_model_.probability_hit);
    tree_->setProbMiss(sensor_model_.probability_miss);
  }

  void doInsert(const SensorFrame& frame, double max_range) override {
    octomap::Pointcloud cloud;
    cloud.reserve(frame.hits.size() + frame.misses.size());
    for (const auto& p : frame.hits) cloud.push_back(toTree(p));
    for (const auto& p : frame.misses) cloud.push_back(toTree(p));
    // Rays are cut at max_range: the misses (placed beyond it) insert free space only.
    // OctoMap's insertPointCloud, spelt out (the same two library calls) so that each updated
    // node comes back and the known state follows it without a search.
    octomap::KeySet free_cells;
    octomap::KeySet occupied_cells;
    tree_->computeDiscreteUpdate(cloud, toTree(frame.origin), free_cells, occupied_cells,
                                 max_range);
    for (const octomap::OcTreeKey& key : free_cells) {
      if (occupied_cells.find(key) == occupied_cells.end()) update(key, false);
    }
    for (const octomap::OcTreeKey& key : occupied_cells) update(key, true);
  }

  void doMarkFree(std::size_t index, const Eigen::Vector3d& center) override {
    const octomap::OcTreeNode* node = tree_->updateNode(toTree(center), false, true);
    if (node) setState(index, tree_->isNodeOccupied(node) ? Voxel::kOccupied : Voxel::kFree);
  }

 private:
  octomap::point3d toTree(const Eigen::Vector3d& p) const {
    const Eigen::Vector3d q = p - lattice().origin();
    return {static_cast<float>(q.x()), static_cast<float>(q.y()), static_cast<float>(q.z())};
  }

  void update(const octomap::OcTreeKey& key, bool hit) {
    // Inner nodes are not updated (lazy): the known state follows the leaves.
    const octomap::OcTreeNode* node = tree_->updateNode(key, hit, /*lazy_eval=*/true);
    // Keys count from the tree's centre, 2^15 voxels from its origin (the map's corner).
    const VoxelIndex voxel(static_cast<int>(key[0]) - 32768, static_cast<int>(key[1]) - 32768,
                           static_cast<int>(key[2]) - 32768);
    if (node && lattice().inside(voxel)) {
      setState(lattice().index(voxel),
               tree_->isNodeOccupied(node) ? Voxel::kOccupied : Voxel::kFree);
    }
  }

  OctomapModel sensor_model_;
  std::optional<octomap::OcTree> tree_;
};

}  // namespace
}  // namespace kinolab

KINOLAB_REGISTER_PLUGINS(registrar) {
  using namespace kinolab;
  registrar.add<VehicleMap>(
      "octomap",
      "OctoMap's probabilistic sensor model: per voxel log-odds that a hit raises and a passing "
      "ray lowers (clamped); occupied above probability 0.5",
      declareFields<OctomapModel>(), [](const ParameterSet& p) {
        return std::make_unique<OctomapVehicleMap>(readFields<OctomapModel>(p));
      });
}
