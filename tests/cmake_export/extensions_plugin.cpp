// A researcher's own extensions, built outside the kinolab tree against an installed kinolab
// (docs/extending/): one library adding a world generator, a lazy lower bound, a heuristic, a
// flight sensor and a vehicle map. No file under framework/ knows them or their parameters;
// world specs, planners and flights choose them by key (`type: pillar_row`,
// `lower_bound=scaled_endpoint`, `heuristic=scaled_time_optimal`, `sensor=ring`,
// `map=obstacles_only`) and set their parameters as `NAME.PARAMETER` (or a YAML mapping).
#include <cmath>

#include "kinolab/core/plugin.hpp"
#include "kinolab/flight/sensor.hpp"
#include "kinolab/flight/vehicle_map.hpp"
#include "kinolab/search/motion_primitive_planner.hpp"
#include "kinolab/world/world_generator.hpp"

namespace {

using namespace kinolab;

/// The paper's endpoint bound scaled by `scale` in [0, 1]. Any scale keeps it a lower bound of
/// the full cost (the endpoint bound is one, and every cost term is non-negative), so the
/// search stays optimal and returns eager's cost; a smaller scale defers more work to pop time.
class ScaledEndpointBound final : public EdgeEvaluationPolicy {
 public:
  explicit ScaledEndpointBound(double scale) : scale_(scale) {}

  EdgeEstimate evaluate(const EdgeEvaluator& evaluator, const ChainState& parent, double,
                        const Eigen::Vector3d& control, EdgeEvaluation& evaluation) const override {
    evaluation = evaluator.partial(parent, control);
    if (evaluation.valid()) evaluation.cost *= scale_;
    return EdgeEstimate::kLowerBound;
  }

 private:
  double scale_;
};

/// time_optimal scaled by `scale` in [0, 1]: still consistent with the edge costs (s h(a) <=
/// s c + s h(b) <= c + s h(b)), so still optimal, with more expansions the smaller the scale.
class ScaledTimeOptimal final : public SearchHeuristic {
 public:
  ScaledTimeOptimal(const HeuristicContext& context, double scale)
      : inner_(context.edges, context.goal_radius), scale_(scale) {}
  double estimate(const ChainState& state, const Eigen::Vector3d& goal) const override {
    return scale_ * inner_.estimate(state, goal);
  }

 private:
  TimeOptimalHeuristic inner_;
  double scale_;
};

/// One horizontal ring of `beams` rays around the vehicle: a planar scanner.
struct RingSensor final : Sensor {
  double range = 4.0;
  double rate = 10.0;
  int beams = 64;

  double maxRange() const override { return range; }
  double frameRate() const override { return rate; }
  std::vector<Eigen::Vector3d> rayDirections() const override {
    std::vector<Eigen::Vector3d> rays;
    for (int beam = 0; beam < beams; ++beam) {
      const double azimuth = 2.0 * M_PI * beam / beams;
      rays.emplace_back(std::cos(azimuth), std::sin(azimuth), 0.0);
    }
    return rays;
  }
};

/// A map that keeps obstacles only: a voxel becomes known occupied after `hits` hits, and
/// free space is never known from rays (only where the body has been).
class ObstaclesOnly final : public VehicleMap {
 public:
  explicit ObstaclesOnly(long long hits) : hits_(hits) {}

 protected:
  void doSetup() override { counts_.assign(lattice().size(), 0); }
  void doInsert(const SensorFrame& frame, double /*max_range*/) override {
    for (const Eigen::Vector3d& hit : frame.hits) {
      const VoxelIndex voxel =
          ((hit - lattice().origin()) / lattice().resolution()).array().floor().cast<int>();
      if (!lattice().inside(voxel)) continue;
      const std::size_t index = lattice().index(voxel);
      if (++counts_[index] >= hits_) setState(index, Voxel::kOccupied);
    }
  }

 private:
  long long hits_;
  std::vector<long long> counts_;
};

/// A row of square pillars along x at height 0 .. `height`, evenly spaced across the bounds.
class PillarRow final : public WorldGenerator {
 public:
  explicit PillarRow(const ParameterSet& parameters)
      : y_(parameters.real("y")),
        count_(parameters.integer("count")),
        width_(parameters.real("width")),
        height_(parameters.real("height")) {}

  void apply(VoxelGrid& grid, Rng&) const override {
    const Box bounds = grid.bounds();
    const double step = (bounds.max.x() - bounds.min.x()) / static_cast<double>(count_ + 1);
    for (long long i = 1; i <= count_; ++i) {
      const Eigen::Vector3d center(bounds.min.x() + step * static_cast<double>(i), y_, 0.0);
      const Eigen::Vector3d half(0.5 * width_, 0.5 * width_, 0.0);
      grid.fillBox(center - half + Eigen::Vector3d(0, 0, bounds.min.z()),
                   center + half + Eigen::Vector3d(0, 0, bounds.min.z() + height_));
    }
  }

 private:
  double y_;
  long long count_;
  double width_;
  double height_;
};

}  // namespace

KINOLAB_REGISTER_PLUGINS(registrar) {
  registrar.add<WorldGenerator>(
      "pillar_row", "a row of square pillars along x",
      ParameterSpecs()
          .real("y", 5.0, -1e4, 1e4, "the row's y, m")
          .integer("count", 3, 0, 1000, "pillars")
          .real("width", 0.4, 0.01, 100.0, "pillar side, m")
          .real("height", 3.0, 0.0, 1e4, "pillar height, m"),
      [](const ParameterSet& parameters) { return std::make_unique<PillarRow>(parameters); });
  registrar.add<EdgeEvaluationPolicy>(
      "scaled_endpoint", "the endpoint bound scaled down (a lazy planner's lower_bound)",
      ParameterSpecs().real("scale", 0.5, 0.0, 1.0, "share of the endpoint bound queued"),
      [](const ParameterSet& parameters) {
        return std::make_unique<ScaledEndpointBound>(parameters.real("scale"));
      });
  registrar.add<HeuristicBuilder>(
      "scaled_time_optimal", "time_optimal scaled down (consistent for any scale <= 1)",
      ParameterSpecs().real("scale", 0.5, 0.0, 1.0, "factor on time_optimal"),
      [](const ParameterSet& parameters) {
        const double scale = parameters.real("scale");
        return std::make_unique<HeuristicBuilder>([scale](const HeuristicContext& context) {
          return std::make_shared<ScaledTimeOptimal>(context, scale);
        });
      });
  const RingSensor ring;
  registrar.add<Sensor>("ring", "one horizontal ring of beams (a planar scanner)",
                        ParameterSpecs()
                            .real("range", ring.range, 0.1, 100.0, "m")
                            .real("rate", ring.rate, 0.5, 100.0, "frames per second")
                            .integer("beams", ring.beams, 4, 100000, "rays around"),
                        [](const ParameterSet& parameters) {
                          auto sensor = std::make_unique<RingSensor>();
                          sensor->range = parameters.real("range");
                          sensor->rate = parameters.real("rate");
                          sensor->beams = static_cast<int>(parameters.integer("beams"));
                          return sensor;
                        });
  registrar.add<VehicleMap>(
      "obstacles_only", "keeps obstacles only: occupied after some hits, free never from rays",
      ParameterSpecs().integer("hits", 1, 1, 1000, "hits that make a voxel known occupied"),
      [](const ParameterSet& parameters) {
        return std::make_unique<ObstaclesOnly>(parameters.integer("hits"));
      });
}
