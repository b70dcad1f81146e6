#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <random>

#include "kinolab/core/error.hpp"
#include "kinolab/view/scene.hpp"
#include "kinolab/world/world_spec.hpp"

namespace kinolab::view {
namespace {

/// A grid with random blobs of occupied voxels (and a floor).
VoxelGrid randomGrid(unsigned seed, double fill) {
  VoxelGrid grid(Box{Eigen::Vector3d::Zero(), Eigen::Vector3d(2.3, 1.7, 1.1)}, 0.1);
  std::mt19937 rng(seed);
  std::bernoulli_distribution occupied(fill);
  const Eigen::Vector3i& n = grid.dims();
  for (int x = 0; x < n.x(); ++x) {
    for (int y = 0; y < n.y(); ++y) {
      for (int z = 0; z < n.z(); ++z) {
        if (z == 0 || occupied(rng)) grid.setOccupied(grid.index(x, y, z), true);
      }
    }
  }
  return grid;
}

/// How many boxes cover each voxel.
std::vector<int> coverCount(const VoxelGrid& grid, const std::vector<VoxelBox>& boxes) {
  std::vector<int> count(grid.size(), 0);
  for (const VoxelBox& box : boxes) {
    for (int x = box.lo[0]; x < box.hi[0]; ++x) {
      for (int y = box.lo[1]; y < box.hi[1]; ++y) {
        for (int z = box.lo[2]; z < box.hi[2]; ++z) ++count[grid.index(x, y, z)];
      }
    }
  }
  return count;
}

TEST(ObstacleBoxes, CoverExactlyTheOccupiedVoxelsOnceEach) {
  for (const unsigned seed : {1u, 2u, 3u}) {
    for (const double fill : {0.05, 0.4, 0.9}) {
      const VoxelGrid grid = randomGrid(seed, fill);
      const std::vector<VoxelBox> boxes = obstacleBoxes(grid);
      const std::vector<int> count = coverCount(grid, boxes);
      for (std::size_t i = 0; i < grid.size(); ++i) {
        ASSERT_EQ(count[i], grid.occupied(i) ? 1 : 0) << "seed " << seed << " fill " << fill;
      }
      EXPECT_LT(boxes.size(), grid.occupiedCount());  // merged, not one box per voxel
    }
  }
}

TEST(ObstacleBoxes, AFloorIsOneBox) {
  VoxelGrid grid(Box{Eigen::Vector3d::Zero(), Eigen::Vector3d(4, 3, 2)}, 0.1);
  grid.fillBox(Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(4, 3, 0.1));
  const std::vector<VoxelBox> boxes = obstacleBoxes(grid);
  ASSERT_EQ(boxes.size(), 1u);
  EXPECT_EQ(boxes[0].lo, (std::array<int, 3>{0, 0, 0}));
  EXPECT_EQ(boxes[0].hi, (std::array<int, 3>{40, 30, 1}));
}

TEST(ObstacleBoxes, ACoarserStrideCoversEveryOccupiedVoxelWithFewerBoxes) {
  const VoxelGrid grid = randomGrid(4, 0.1);
  const std::vector<VoxelBox> fine = obstacleBoxes(grid);
  const std::vector<VoxelBox> coarse = obstacleBoxes(grid, 4);
  EXPECT_LT(coarse.size(), fine.size());
  const std::vector<int> count = coverCount(grid, coarse);
  for (std::size_t i = 0; i < grid.size(); ++i) {
    ASSERT_LE(count[i], 1);
    if (grid.occupied(i)) {
      ASSERT_EQ(count[i], 1);
    }
  }
  const auto [boxes, stride] = viewerBoxes(grid, coarse.size());
  EXPECT_LE(boxes.size(), coarse.size());
  EXPECT_GT(stride, 1);
  EXPECT_THROW(obstacleBoxes(grid, 0), InvalidArgument);
}

TEST(ObstacleBoxes, AHugeSparseWorldsViewerGridIsCoarseEnoughToHold) {
  // 2048 x 1024 x 128 voxels (2^28): a byte a voxel would be 256 MiB, twice the cap, so the
  // viewer's boxes start at stride 2, and still cover the one box.
  VoxelGrid grid(Box{Eigen::Vector3d::Zero(), Eigen::Vector3d(204.8, 102.4, 12.8)}, 0.1,
                 GridLayout::kBricked);
  grid.fillBox(Eigen::Vector3d(10, 10, 0), Eigen::Vector3d(20.1, 15.1, 5.1));
  const auto [boxes, stride] = viewerBoxes(grid);
  EXPECT_EQ(stride, 2);
  ASSERT_EQ(boxes.size(), 1u);
  EXPECT_EQ(boxes[0].lo, (std::array<int, 3>{100, 100, 0}));
  EXPECT_EQ(boxes[0].hi, (std::array<int, 3>{202, 152, 52}));
}

TEST(Scene, HoldsTheWorldTrajectoriesTreesAndFlights) {
  const auto world = World::build(WorldSpec::fromText(
      "name: s\nresolution: 0.1\nbounds: {min: [0, 0, 0], max: [4, 4, 2]}\n"
      "generators: [{type: box_list, boxes: [{min: [1, 1, 0], max: [2, 2, 2]}]}]\n",
      "scene.yaml", "."));
  Scene scene("a </script> title");
  scene.setWorld(*world);
  const int query = scene.addQuery("q", Eigen::Vector3d(0.5, 0.5, 1), Eigen::Vector3d(3.5, 3.5, 1));
  Trajectory line;
  TrajectorySegment segment;
  segment.duration = 2.0;
  segment.coefficients = Eigen::Matrix<double, 3, Eigen::Dynamic>::Zero(3, 2);
  segment.coefficients.col(0) = Eigen::Vector3d(0.5, 0.5, 1);
  segment.coefficients.col(1) = Eigen::Vector3d(1.5, 1.5, 0);
  line.append(segment);
  scene.addTrajectory(query, "p", line, 0.5);
  SearchTree tree(2);
  tree[0].points = {Eigen::Vector3d(0, 0, 1), Eigen::Vector3d(1, 0, 1), Eigen::Vector3d(2, 0, 1)};
  tree[0].state = SearchTreeEdge::State::kPartial;
  tree[1].points = {Eigen::Vector3d(0, 0, 1), Eigen::Vector3d(0, 1, 1)};
  tree[1].state = SearchTreeEdge::State::kRejected;
  scene.addTree(query, "p", tree);
  scene.addFlight(
      query, "p", line,
      {{0.0, Eigen::Vector3d(1.05, 1.05, 0.05)}, {1.5, Eigen::Vector3d(1.15, 1.05, 0.05)}}, 0.1,
      0.5);
  EXPECT_THROW(scene.addTree(5, "p", tree), InvalidArgument);

  const auto json = nlohmann::json::parse(scene.json());
  EXPECT_EQ(json["format"], "kinolab-scene");
  EXPECT_EQ(json["world"]["boxes"], (nlohmann::json{10, 10, 0, 20, 20, 20}));
  const auto& q = json["queries"][0];
  EXPECT_EQ(q["trajectories"][0]["points"].size(), 5u * 3u);          // t = 0, 0.5, ..., 2
  EXPECT_EQ(q["trees"][0]["edges"]["partial"].size(), 2u * 2u * 3u);  // two segments
  EXPECT_EQ(q["trees"][0]["edges"]["rejected"].size(), 1u * 2u * 3u);
  EXPECT_TRUE(q["trees"][0]["edges"]["full"].empty());
  // The flight every 0.5 s; its known voxels as x, y, z, first seen.
  EXPECT_EQ(q["flights"][0]["t"], (nlohmann::json{0.0, 0.5, 1.0, 1.5, 2.0}));
  EXPECT_EQ(q["flights"][0]["known"]["size"], 0.1);
  EXPECT_EQ(q["flights"][0]["known"]["points"],
            (nlohmann::json{1.05, 1.05, 0.05, 0.0, 1.15, 1.05, 0.05, 1.5}));

  // The page inlines the scene where its element cannot be closed early.
  const auto directory = std::filesystem::temp_directory_path() / "kinolab_view_test";
  std::filesystem::create_directories(directory);
  const auto page = directory / "page.html";
  std::ofstream(page) << "<script type=\"application/json\">__KINOLAB_SCENE__</script>";
  setenv("KINOLAB_VIEWER", page.c_str(), 1);
  const std::string html = viewHtml(scene.json());
  unsetenv("KINOLAB_VIEWER");
  EXPECT_NE(html.find("a <\\/script> title"), std::string::npos);
  EXPECT_EQ(html.find("</script>"), html.rfind("</script>"));
  std::filesystem::remove_all(directory);
}

}  // namespace
}  // namespace kinolab::view
