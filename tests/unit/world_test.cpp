#include "kinolab/world/world.hpp"

#include <gtest/gtest.h>
#include <octomap/OcTree.h>

#include <filesystem>
#include <fstream>
#include <set>

#include "kinolab/core/error.hpp"
#include "kinolab/core/random.hpp"
#include "kinolab/core/yaml_reader.hpp"
#include "kinolab/experiment/query_sampler.hpp"
#include "kinolab/world/world_export.hpp"
#include "kinolab/world/world_spec.hpp"
#include "support/arrays.hpp"
#include "support/errors.hpp"

namespace kinolab {
namespace {

const std::string kSourceDir = KINOLAB_SOURCE_DIR;

WorldSpec specFromText(const std::string& text, const std::string& directory = ".") {
  return WorldSpec::fromYaml(YamlReader::loadString(text, "spec.yaml"), directory);
}

/// The ConfigError reading the spec `text` throws.
std::string configErrorOf(const std::string& text) {
  return test::errorOf<ConfigError>([&] { specFromText(text); });
}

TEST(WorldSpecTest, EveryShippedWorldLoadsAndBuilds) {
  for (const char* name : {"forest", "complex", "walls", "boxes", "empty", "geb079", "city"}) {
    const WorldSpec spec = WorldSpec::fromFile(kSourceDir + "/configs/worlds/" + name + ".yaml");
    EXPECT_EQ(spec.name, name);
    const VoxelGrid grid = World::buildGrid(spec);
    const double occupancy = static_cast<double>(grid.occupiedCount()) / grid.size();
    if (std::string(name) == "empty") {
      EXPECT_EQ(occupancy, 0.0);
    } else {
      EXPECT_GT(occupancy, 0.005) << name;
      EXPECT_LT(occupancy, 0.3) << name;
    }
  }
}

/// A world of every random generator (seed 4, 20 m x 20 m x 4 m at 0.2 m).
const std::string kEveryRandomGenerator =
    "seed: 4\nresolution: 0.2\nbounds: {min: [0, 0, 0], max: [20, 20, 4]}\n"
    "generators:\n  - {type: forest, density: 0.1, canopy: {probability: 0.5}}\n"
    "  - {type: boxes, count: 10, on_ground: false}\n  - {type: walls, cell_size: 5}\n";

TEST(WorldSpecTest, SameSpecSameGridBitForBitAndSeedMatters) {
  const std::string text = kEveryRandomGenerator;
  const WorldSpec a = specFromText(text);
  const WorldSpec b = specFromText(text);
  EXPECT_EQ(a.hash(), b.hash());
  EXPECT_EQ(asVector(World::buildGrid(a).occupancy()), asVector(World::buildGrid(b).occupancy()));
  const WorldSpec other_seed = specFromText("seed: 5" + text.substr(7));
  EXPECT_NE(other_seed.hash(), a.hash());
  EXPECT_NE(asVector(World::buildGrid(other_seed).occupancy()),
            asVector(World::buildGrid(a).occupancy()));
  // Defaults written out explicitly give the same world; the name is only a label.
  const WorldSpec explicit_defaults = specFromText(
      "name: other\nseed: 4\nresolution: 0.2\nbounds: {min: [0, 0, 0], max: [20, 20, 4]}\n"
      "generators:\n  - {type: forest, density: 0.1, canopy: {probability: 0.5}, "
      "ground_plane: true, min_spacing: 1.0}\n"
      "  - {type: boxes, count: 10, on_ground: false}\n  - {type: walls, cell_size: 5}\n");
  EXPECT_EQ(explicit_defaults.hash(), a.hash());
}

TEST(WorldSpecTest, TheSameSeedMakesTheSameWorldAndQueriesOnEveryCompiler) {
  // Pinned: a world of every random generator and queries drawn in it, as g++ has always made
  // them. Draws that were the arguments of one call came out in another order under clang
  // (C++ leaves it open), so clang made other worlds and queries from the same seeds; a build
  // by any compiler must make these.
  const auto world = World::build(specFromText(kEveryRandomGenerator));
  std::uint64_t hash = 1469598103934665603ull;  // FNV-1a over the occupancy
  for (const std::uint8_t value : world->grid().occupancy())
    hash = (hash ^ value) * 1099511628211ull;
  EXPECT_EQ(hash, 0x08913787ddd8ab1aull) << std::hex << hash;
  EXPECT_EQ(world->grid().occupiedCount(), 30655u);
  Rng rng(9);
  const auto queries =
      sampleFreeQueries(*world, {{{1, 1, 0.5}, {19, 19, 3}}, 0.3, 2.0, 15.0}, 2, rng, "pinned");
  ASSERT_EQ(queries.size(), 2u);
  EXPECT_EQ(queries[0].start.col(0),
            Eigen::Vector3d(14.399356795000118, 17.570530328044331, 2.3317360634271855));
  EXPECT_EQ(queries[1].goal,
            Eigen::Vector3d(3.5524127005434458, 11.485730355761712, 1.1442058842849625));
}

TEST(WorldSpecTest, GeneratorsComposeAsAUnion) {
  const std::string head =
      "seed: 2\nresolution: 0.25\nbounds: {min: [0, 0, 0], max: [16, 16, 4]}\ngenerators:\n";
  const std::string forest = "  - {type: forest, density: 0.08, ground_plane: false}\n";
  const std::string boxes = "  - {type: boxes, count: 12}\n";
  const VoxelGrid only_forest = World::buildGrid(specFromText(head + forest));
  const VoxelGrid both = World::buildGrid(specFromText(head + forest + boxes));
  std::size_t added = 0;
  for (std::size_t i = 0; i < both.size(); ++i) {
    if (only_forest.occupied(i)) {
      ASSERT_TRUE(both.occupied(i));
    }
    added += both.occupied(i) && !only_forest.occupied(i);
  }
  EXPECT_GT(added, 0u);
  // Each generator has its own stream: adding boxes leaves the trees where they were.
  const VoxelGrid boxes_first = World::buildGrid(specFromText(head + boxes + forest));
  EXPECT_NE(asVector(boxes_first.occupancy()), asVector(both.occupancy()));
}

TEST(WorldSpecTest, ForestTrunksHaveTheirHeightsAndCount) {
  const WorldSpec spec = specFromText(
      "seed: 1\nresolution: 0.1\nbounds: {min: [0, 0, 0], max: [20, 20, 6]}\ngenerators:\n"
      "  - {type: forest, density: 0.05, trunk_radius: [0.2, 0.2], trunk_height: [3, 3], "
      "min_spacing: 1.5, ground_plane: false}\n");
  const VoxelGrid grid = World::buildGrid(spec);
  // Nothing above 3 m, something below.
  std::size_t high = 0;
  std::size_t low = 0;
  for (int ix = 0; ix < grid.dims().x(); ++ix) {
    for (int iy = 0; iy < grid.dims().y(); ++iy) {
      for (int iz = 0; iz < grid.dims().z(); ++iz) {
        if (!grid.occupied(grid.index(ix, iy, iz))) continue;
        (grid.center({ix, iy, iz}).z() > 3.0 ? high : low)++;
      }
    }
  }
  EXPECT_EQ(high, 0u);
  // 20 trees of radius 0.2 m (about 12 voxels in cross-section) and 30 layers each.
  EXPECT_NEAR(static_cast<double>(low), 20 * 12.6 * 30, 20 * 12.6 * 30 * 0.25);
}

TEST(WorldSpecTest, ACityHasFreeStreetsBuildingsOfTheirHeightsAndStreetTrees) {
  // Fixed sizes make the plan known: blocks [0, 50], [60, 110], [120, 170] on both axes,
  // streets of 10 m between them, lots of 25 m with buildings 2 m in from their edges.
  const std::string head =
      "seed: 3\nresolution: 0.5\nbounds: {min: [0, 0, 0], max: [180, 180, 40]}\ngenerators:\n"
      "  - {type: city, region: {x: [0, 170], y: [0, 170]}, block_size: [50, 50], "
      "street_width: 10, lot_size: [25, 25], setback: 2, "
      "building_height: [10, 30], building_probability: 1, ground_plane: false, ";
  const VoxelGrid bare = World::buildGrid(specFromText(head + "tree_spacing: 0}\n"));
  const VoxelGrid treed = World::buildGrid(specFromText(
      head +
      "tree_spacing: 10, tree_offset: 2.5, trunk_radius: [0.4, 0.4], tree_height: [6, 6], "
      "canopy_radius: [2, 2], canopy_thickness: [2, 2]}\n"));
  const auto occupied = [](const VoxelGrid& grid, double x, double y, double z) {
    const Eigen::Vector3d local = (Eigen::Vector3d(x, y, z) - grid.origin()) / grid.resolution();
    return grid.occupied(grid.index(VoxelIndex(local.array().floor().cast<int>())));
  };
  // 36 lots, each built: a building from (lot + 2) to (lot + 23) of 10-30 m, solid to its roof.
  int buildings = 0;
  for (const double bx : {0.0, 60.0, 120.0}) {
    for (const double by : {0.0, 60.0, 120.0}) {
      for (const double lx : {bx, bx + 25.0}) {
        for (const double ly : {by, by + 25.0}) {
          const double cx = lx + 12.5;
          const double cy = ly + 12.5;
          ASSERT_TRUE(occupied(bare, cx, cy, 9.75)) << cx << " " << cy;
          EXPECT_FALSE(occupied(bare, cx, cy, 30.25)) << cx << " " << cy;
          EXPECT_TRUE(occupied(bare, lx + 2.25, ly + 2.25, 0.25));   // the building's corner
          EXPECT_FALSE(occupied(bare, lx + 1.75, ly + 12.5, 0.25));  // the setback
          EXPECT_FALSE(occupied(bare, lx + 23.25, ly + 12.5, 0.25));
          ++buildings;
        }
      }
    }
  }
  EXPECT_EQ(buildings, 36);
  // Heights vary: not every roof at the same height.
  std::set<int> roofs;
  for (int ix = 0; ix < bare.dims().x(); ix += 10) {
    for (int iy = 0; iy < bare.dims().y(); iy += 10) {
      int top = -1;
      for (int iz = 0; iz < bare.dims().z(); ++iz) {
        if (bare.occupied(bare.index(ix, iy, iz))) top = iz;
      }
      if (top >= 0) roofs.insert(top);
    }
  }
  EXPECT_GT(roofs.size(), 10u);
  // Streets are free to the sky without trees; with them, trunks stand 2.5 m out from the
  // blocks every 10 m (the first 5 m from a corner), canopies from 4 to 6 m, the middle of the
  // street free.
  for (double t = 0.25; t < 170.0; t += 0.5) {
    for (const double street : {55.0, 115.0}) {
      for (const double z : {0.25, 5.25, 20.25}) {
        ASSERT_FALSE(occupied(bare, street, t, z)) << street << " " << t << " " << z;
        ASSERT_FALSE(occupied(bare, t, street, z)) << t << " " << street << " " << z;
      }
      ASSERT_FALSE(occupied(treed, street, t, 1.25)) << street << " " << t;
    }
  }
  EXPECT_TRUE(occupied(treed, 5.0, 52.5, 1.25));    // a trunk south of the street at y 55
  EXPECT_TRUE(occupied(treed, 5.0, 57.5, 1.25));    // and north of it
  EXPECT_TRUE(occupied(treed, 52.5, 65.0, 1.25));   // along a block's east side
  EXPECT_FALSE(occupied(treed, 10.0, 52.5, 1.25));  // between trunks
  EXPECT_TRUE(occupied(treed, 6.5, 52.5, 5.25));    // its canopy
  EXPECT_FALSE(occupied(treed, 6.5, 52.5, 6.25));   // above it
  EXPECT_TRUE(occupied(treed, 5.0, 117.5, 1.25));   // north of the middle row of blocks
  EXPECT_FALSE(occupied(treed, 5.0, 172.5, 1.25));  // but none north of the last: the region ends
}

TEST(WorldSpecTest, ACityThatWouldNeverFinishIsRefusedWithTheEstimate) {
  const std::string head =
      "seed: 3\nresolution: 10\nbounds: {min: [0, 0, 0], max: [10000, 10000, 40]}\n"
      "generators:\n  - {type: city, ";
  EXPECT_NE(configErrorOf(head + "tree_spacing: 0.1}\n")
                .find("'tree_spacing': expected 0 (no "
                      "street trees) or at least 0.5"),
            std::string::npos);
  const auto refusal = [&](const std::string& parameters) {
    return test::errorOf<ConfigError>(
        [&] { World::buildGrid(specFromText(head + parameters + "}\n")); });
  };
  EXPECT_NE(
      refusal("lot_size: [2, 30], tree_spacing: 0").find("'lot_size': up to 26863489 lots of 2 m"),
      std::string::npos)
      << refusal("lot_size: [2, 30], tree_spacing: 0");
  EXPECT_NE(refusal("block_size: [40, 40], street_width: 0, lot_size: [10000, 10000], "
                    "tree_spacing: 0.5")
                .find("'tree_spacing': up to"),
            std::string::npos);
  // Every block has a lot, however large lot_size is.
  EXPECT_NE(refusal("block_size: [2, 2], street_width: 0, lot_size: [10000, 10000], "
                    "tree_spacing: 0")
                .find("'lot_size': up to"),
            std::string::npos);
  EXPECT_EQ(refusal("lot_size: [40, 60], tree_spacing: 20"), "");  // accepted
}

TEST(WorldSpecTest, BoxesThatWouldNeverFinishAreRefusedWithTheEstimateBeforeAnyIsFilled) {
  // 1251 boxes, each the whole 8e6-voxel world: 1.0008e10 voxel writes densely, past the cap;
  // a sparse grid fills whole bricks at one write each (15625 a box), so it builds.
  std::string boxes = "[&whole {min: [0, 0, 0], max: [100, 100, 0.8]}";
  for (int i = 0; i < 1250; ++i) boxes += ", *whole";
  const std::string text =
      "seed: 3\nresolution: 0.1\nbounds: {min: [0, 0, 0], max: [100, 100, 0.8]}\n"
      "generators: [{type: box_list, boxes: " +
      boxes + "]}]\n";
  const std::string refusal =
      test::errorOf<ConfigError>([&] { World::buildGrid(specFromText(text)); });
  EXPECT_NE(refusal.find("generators[0] (box_list): parameter 'boxes': 1251 boxes fill about "
                         "1.0008e+10 voxels in this grid (overlaps counted each time); at most "
                         "1e+10"),
            std::string::npos)
      << refusal;
  const VoxelGrid sparse = World::buildGrid(specFromText(text + "layout: sparse\n"));
  EXPECT_EQ(sparse.occupiedCount(), sparse.size());
}

TEST(WorldExportTest, ASparseWorldsTopViewIsTheDenseOnesAndItsArraysAreSaidMissingUpFront) {
  // The sparse top view reads a brick's row at a time: the same picture as voxel by voxel, on
  // a world whose height (29 voxels) is no multiple of a brick.
  const std::string text =
      "seed: 3\nresolution: 0.1\nbounds: {min: [0, 0, 0], max: [6, 5, 2.9]}\n"
      "generators: [{type: boxes, count: 12}, {type: box_list, boxes: [{min: [1, 1, 2.75], "
      "max: [2, 2, 2.9]}]}]\n";
  const auto dense = World::build(specFromText(text));
  const auto sparse = World::build(specFromText(text + "layout: sparse\ntruncation: 1\n"));
  EXPECT_EQ(renderTopView(*sparse).pixels, renderTopView(*dense).pixels);
  EXPECT_EQ(arraysNotExported(GridLayout::kBricked, kMostExportedSparseVoxels), "");
  EXPECT_EQ(arraysNotExported(GridLayout::kDense, 1e9), "");
  EXPECT_NE(arraysNotExported(GridLayout::kBricked, 7.5e9)
                .find("a sparse world of 7.5e+09 voxels is too large for dense arrays"),
            std::string::npos);
  EXPECT_EQ(specFromText(text).voxels(), 60.0 * 50.0 * 29.0);
}

TEST(VoxelGridTest, FillCostCountsTheWritesFillBoxMakes) {
  const Box bounds{{0, 0, 0}, {3, 3, 3}};  // 30^3 voxels, bricks of 8 (the last 6 wide)
  VoxelGrid dense(bounds, 0.1);
  const Eigen::Vector3d low(0.42, 0.42, 0.42);  // voxel centres 4..19 on every axis
  const Eigen::Vector3d high(1.97, 1.97, 1.97);
  EXPECT_EQ(dense.fillCost(low, high), 4096.0);
  dense.fillBox(low, high);
  EXPECT_EQ(dense.occupiedCount(), 4096u);
  // Bricked: 27 bricks touched, brick (1, 1, 1) covered whole: 27 + 4096 - 512.
  EXPECT_EQ(VoxelGrid(bounds, 0.1, GridLayout::kBricked).fillCost(low, high), 3611.0);
  // A whole grid: one write per brick (64), none voxel by voxel but the 6-wide end bricks'.
  const double whole =
      VoxelGrid(bounds, 0.1, GridLayout::kBricked).fillCost(bounds.min, bounds.max);
  EXPECT_EQ(whole, 64.0 + 27000.0 - 27.0 * 512.0);
  EXPECT_EQ(dense.fillCost({5, 5, 5}, {6, 6, 6}), 0.0);  // outside
}

TEST(WorldSpecTest, OctomapOccupiedLeavesBecomeOccupiedVoxels) {
  const WorldSpec free_unknown = WorldSpec::fromFile(kSourceDir + "/configs/worlds/geb079.yaml");
  const VoxelGrid grid = World::buildGrid(free_unknown);
  EXPECT_DOUBLE_EQ(grid.resolution(), 0.08);
  // geb079.bt has 143,729 occupied 8 cm leaves (its README); pruned inner nodes can only
  // cover more, never fewer, voxels.
  EXPECT_GE(grid.occupiedCount(), 143729u);
  EXPECT_LT(grid.occupiedCount(), 143729u * 2);
  const WorldSpec unknown_occupied = specFromText(
      "resolution: 0.08\ngenerators:\n  - {type: octomap, file: data/maps/geb079.bt, "
      "unknown: occupied}\n",
      kSourceDir);
  EXPECT_GT(World::buildGrid(unknown_occupied).occupiedCount(), grid.occupiedCount() * 3);
  EXPECT_NE(unknown_occupied.hash(), free_unknown.hash());
}

TEST(WorldSpecTest, ResampledMapsKeepEveryObstacle) {
  // At another resolution, and at the map's own on a grid shifted by 3 cm, every occupied
  // leaf's cube stays covered: its centre and points just inside each of its corners lie in
  // occupied voxels (a centre test loses about half the leaves at 0.1 m).
  octomap::OcTree tree(0.1);
  ASSERT_TRUE(tree.readBinary(kSourceDir + "/data/maps/geb079.bt"));
  for (const std::string& grid_text :
       {std::string("resolution: 0.1\n"), std::string("resolution: 0.05\n"),
        std::string(
            "resolution: 0.08\nbounds: {min: [-8.03, -7.55, -0.35], max: [31, 7.5, 2.9]}\n")}) {
    const WorldSpec spec = specFromText(
        grid_text + "generators:\n  - {type: octomap, file: data/maps/geb079.bt}\n", kSourceDir);
    const VoxelGrid grid = World::buildGrid(spec);
    long long checked = 0;
    for (auto leaf = tree.begin_leafs(), end = tree.end_leafs(); leaf != end; ++leaf) {
      if (!tree.isNodeOccupied(*leaf)) continue;
      const double inside = 0.49 * leaf.getSize();
      const Eigen::Vector3d centre(leaf.getX(), leaf.getY(), leaf.getZ());
      for (int corner = 0; corner < 9; ++corner) {
        Eigen::Vector3d point = centre;
        if (corner < 8) {
          for (int axis = 0; axis < 3; ++axis)
            point[axis] += (corner >> axis & 1 ? 1 : -1) * inside;
        }
        const VoxelIndex voxel =
            ((point - grid.origin()) / grid.resolution()).array().floor().cast<int>();
        if (!grid.inside(voxel)) continue;
        ASSERT_TRUE(grid.occupied(voxel))
            << grid_text << "an occupied leaf at " << centre.transpose() << " lost";
        ++checked;
      }
    }
    EXPECT_GT(checked, 143729);
  }
  // Aligned and at its own resolution, the grid is the map: no dilation.
  const VoxelGrid own =
      World::buildGrid(WorldSpec::fromFile(kSourceDir + "/configs/worlds/geb079.yaml"));
  const VoxelGrid centred = World::buildGrid(specFromText(
      "resolution: 0.08\nbounds: {min: [-8.0, -7.52, -0.32], max: [30.96, 7.44, 2.8]}\n"
      "generators:\n  - {type: octomap, file: data/maps/geb079.bt}\n",
      kSourceDir));
  EXPECT_EQ(own.occupiedCount(), centred.occupiedCount());
}

TEST(WorldSpecTest, SizesAndValuesOutsideWhatIsHandledExactlyAreRefusedUpFront) {
  // A 10 km corridor at 0.1 m: squared voxel distances would overflow the exact ESDF.
  EXPECT_NE(configErrorOf("resolution: 0.1\nbounds: {min: [0, 0, 0], max: [10000, 2, 2]}\n"
                          "generators: [{type: box_list, boxes: []}]\n")
                .find("at most 23170 voxels of diagonal"),
            std::string::npos);
  EXPECT_NE(configErrorOf("resolution: 0.001\nbounds: {min: [0, 0, 0], max: [1000, 1000, 10]}\n"
                          "generators: [{type: box_list, boxes: []}]\n")
                .find("a dense world holds at most 1e9"),
            std::string::npos);
  EXPECT_NE(configErrorOf("resolution: 0.1\nbounds: {min: [0, 0, 0], max: [.nan, 2, 2]}\n"
                          "generators: [{type: box_list, boxes: []}]\n")
                .find("bounds"),
            std::string::npos);
  // An OctoMap whose header claims a nonsensical resolution is refused, not turned into an
  // empty one-voxel world.
  const auto directory = std::filesystem::temp_directory_path() / "kinolab_tiny_resolution";
  std::filesystem::create_directories(directory);
  octomap::OcTree tiny(1e-9);
  tiny.updateNode(octomap::point3d(0, 0, 0), true);
  ASSERT_TRUE(tiny.writeBinary((directory / "tiny.bt").string()));
  EXPECT_NE(configErrorOf("resolution: 0.1\ngenerators:\n  - {type: octomap, file: " +
                          (directory / "tiny.bt").string() + "}\n")
                .find("resolution of 1e-09 m; expected 0.0001 to 100 m"),
            std::string::npos);
  std::filesystem::remove_all(directory);
}

TEST(WorldSpecTest, ASparseWorldHoldsTheSameVoxelsAsADenseOne) {
  // Every generator's output, bricked: the same occupied voxels, by index and by voxel, and
  // bricks only where a surface is (a city's insides and open air take none).
  for (const std::string& text :
       {kEveryRandomGenerator,
        std::string("seed: 3\nresolution: 0.5\nbounds: {min: [0, 0, 0], max: [130, 90, 30]}\n"
                    "generators:\n  - {type: city, block_size: [30, 50], street_width: 10, "
                    "lot_size: [10, 20], building_height: [5, 25], tree_spacing: 9}\n")}) {
    const WorldSpec dense_spec = specFromText(text);
    const WorldSpec sparse_spec = specFromText(text + "layout: sparse\n");
    EXPECT_NE(dense_spec.hash(), sparse_spec.hash());
    const VoxelGrid dense = World::buildGrid(dense_spec);
    const VoxelGrid sparse = World::buildGrid(sparse_spec);
    ASSERT_EQ(sparse.layout(), GridLayout::kBricked);
    ASSERT_EQ(sparse.dims(), dense.dims());
    EXPECT_EQ(sparse.occupiedCount(), dense.occupiedCount());
    std::size_t differ = 0;
    for (std::size_t i = 0; i < dense.size(); ++i) {
      differ += dense.occupied(i) != sparse.occupied(i) ||
                dense.occupied(dense.voxel(i)) != sparse.occupied(dense.voxel(i));
    }
    EXPECT_EQ(differ, 0u);
    std::size_t visited = 0;
    sparse.forEachOccupied([&](const VoxelIndex& v) { visited += dense.occupied(v) ? 1 : 0; });
    EXPECT_EQ(visited, dense.occupiedCount());
    EXPECT_LT(sparse.memoryBytes(), dense.memoryBytes() / 4);
    EXPECT_THROW((void)sparse.occupancy(), InvalidArgument);
  }
}

TEST(WorldSpecTest, ALayoutOrTruncationThatIsNotUnderstoodIsRefused) {
  const std::string base =
      "resolution: 0.1\nbounds: {min: [0, 0, 0], max: [10, 10, 3]}\n"
      "generators: [{type: box_list, boxes: []}]\n";
  EXPECT_NE(configErrorOf(base + "layout: spares\n").find("unknown layout 'spares'"),
            std::string::npos);
  EXPECT_NE(configErrorOf(base + "layout: spares\n").find("sparse"), std::string::npos);
  EXPECT_NE(configErrorOf(base + "truncation: 1\n").find("truncation applies to a sparse world"),
            std::string::npos);
  // Below a voxel or above 90 voxels.
  EXPECT_NE(configErrorOf(base + "layout: sparse\ntruncation: 0.05\n").find("truncation"),
            std::string::npos);
  EXPECT_NE(configErrorOf(base + "layout: sparse\ntruncation: 9.5\n").find("truncation"),
            std::string::npos);
  EXPECT_EQ(specFromText(base + "layout: sparse\ntruncation: 0.5\n").truncation, 0.5);
  // The default of 2 m is checked as a given value would be: over 90 voxels of 0.02 m, under
  // one voxel of 3 m.
  for (const char* resolution : {"0.02", "3"}) {
    EXPECT_NE(configErrorOf("resolution: " + std::string(resolution) +
                            "\nbounds: {min: [0, 0, 0], max: [6, 6, 6]}\n"
                            "generators: [{type: box_list, boxes: []}]\nlayout: sparse\n")
                  .find("the default truncation of 2 m"),
              std::string::npos)
        << resolution;
  }
  // Longer than OctoMap's keys reach (2^15 voxels): the checker's trees are per tile.
  EXPECT_EQ(specFromText("resolution: 0.1\nbounds: {min: [0, 0, 0], max: [4000, 10, 10]}\n"
                         "generators: [{type: box_list, boxes: []}]\nlayout: sparse\n")
                .layout,
            GridLayout::kBricked);
  // A 1 km city at 0.2 m is sparse's to hold, not dense's; 10^13 voxels are no one's.
  const std::string city =
      "resolution: 0.2\nbounds: {min: [0, 0, 0], max: [1000, 1000, 60]}\n"
      "generators: [{type: box_list, boxes: []}]\n";
  EXPECT_NE(configErrorOf(city).find("a dense world holds at most 1e9"), std::string::npos);
  EXPECT_EQ(specFromText(city + "layout: sparse\n").layout, GridLayout::kBricked);
  EXPECT_NE(configErrorOf("resolution: 0.01\nbounds: {min: [0, 0, 0], max: [1000, 1000, 100]}\n"
                          "generators: [{type: box_list, boxes: []}]\nlayout: sparse\n"
                          "truncation: 0.5\n")
                .find("a sparse world holds at most 1e12"),
            std::string::npos);
}

TEST(WorldSpecTest, FullOtMapsLoadLikeBinaryBtMaps) {
  // The same tree written as a full .ot file gives the same grid as the .bt file.
  const auto directory = std::filesystem::temp_directory_path() / "kinolab_ot_test";
  std::filesystem::create_directories(directory);
  octomap::OcTree tree(0.1);
  ASSERT_TRUE(tree.readBinary(kSourceDir + "/data/maps/geb079.bt"));
  ASSERT_TRUE(tree.write((directory / "geb079.ot").string()));
  const std::string spec = "resolution: 0.08\ngenerators:\n  - {type: octomap, file: ";
  const VoxelGrid from_bt =
      World::buildGrid(specFromText(spec + "data/maps/geb079.bt}\n", kSourceDir));
  const VoxelGrid from_ot =
      World::buildGrid(specFromText(spec + "geb079.ot}\n", directory.string()));
  EXPECT_EQ(from_ot.dims(), from_bt.dims());
  EXPECT_EQ(asVector(from_ot.occupancy()), asVector(from_bt.occupancy()));
  EXPECT_GT(from_ot.occupiedCount(), 0u);
  std::filesystem::remove_all(directory);
}

TEST(WorldSpecTest, CorruptOrMissingMapFilesAreClearErrors) {
  const auto directory = std::filesystem::temp_directory_path() / "kinolab_world_test";
  std::filesystem::create_directories(directory);
  {
    std::ifstream in(kSourceDir + "/data/maps/geb079.bt", std::ios::binary);
    std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    std::ofstream(directory / "truncated.bt", std::ios::binary) << bytes.substr(0, 100);
    std::ofstream(directory / "garbage.bt", std::ios::binary) << "not an octree\n";
    // Inside the node data: cut in half, a flag byte set to "inner" everywhere (deeper than
    // OctoMap's 16 levels or past the end, where OctoMap read uninitialised flags), a header
    // that promises more nodes than the bytes can hold.
    const std::size_t data = bytes.find("data\n") + 5;
    std::ofstream(directory / "half.bt", std::ios::binary) << bytes.substr(0, bytes.size() / 2);
    std::string inner = bytes;
    for (std::size_t i = data + 1000; i < inner.size(); i += 2) inner[i] = '\xff';
    std::ofstream(directory / "inner.bt", std::ios::binary) << inner;
    std::string chain;  // 20 nodes, each the one inner child of the one before, then a leaf
    for (int level = 0; level < 20; ++level) chain += std::string("\x03\x00", 2);
    std::ofstream(directory / "deep.bt", std::ios::binary)
        << "# Octomap OcTree binary file\nid OcTree\nsize 21\nres 0.1\ndata\n"
        << chain << std::string("\x00\x00", 2);
    std::ofstream(directory / "promise.bt", std::ios::binary)
        << "# Octomap OcTree binary file\nid OcTree\nsize 710980\nres 0.1\ndata\n"
        << std::string("\xff\xff", 2);
  }
  std::ofstream(directory / "map.txt") << "not a map\n";
  for (const char* file : {"truncated.bt", "garbage.bt", "missing.bt", "map.txt", "half.bt",
                           "inner.bt", "deep.bt", "promise.bt"}) {
    try {
      specFromText(
          std::string("resolution: 0.1\ngenerators:\n  - {type: octomap, file: ") + file + "}\n",
          directory.string());
      ADD_FAILURE() << file << " was accepted";
    } catch (const ConfigError& error) {
      const std::string message = error.what();
      EXPECT_NE(message.find(file), std::string::npos) << message;
      EXPECT_NE(message.find("generators[0].file"), std::string::npos) << message;
    }
  }
  std::filesystem::remove_all(directory);
}

TEST(WorldSpecTest, BadSpecsNameTheKeyAndLine) {
  const std::string bounds = "bounds: {min: [0, 0, 0], max: [10, 10, 3]}\n";
  // Nothing malformed is read as something else: a list or a mapping for a number, an empty
  // or incomplete box, a box list without boxes.
  for (const auto& [generator, expected] : std::vector<std::pair<std::string, std::string>>{
           {"{type: forest, density: [0.1]}", "parameter 'density': expected a number"},
           {"{type: forest, density: {type: 3}}", "not a mapping"},
           {"{type: forest, ground_plane: {}}", "not a mapping"},
           {"{type: box_list, boxes: [{}]}", "generators[0].boxes[0]: an empty item"},
           {"{type: box_list}", "missing parameter 'boxes'"},
           {"{type: box_list, boxes: [{min: [1, 1, 0], max: [2, 2, 2]}, {min: [1, 1, 0]}]}",
            "generators[0].boxes[1].min: world 'box_list': boxes[1]: missing parameter 'max'"},
           {"{type: box_list, boxes: [{min: [[1], [1, 0]], max: [2, 2, 2]}]}",
            "expected 3 numbers"}}) {
    EXPECT_NE(configErrorOf("resolution: 0.1\n" + bounds + "generators: [" + generator + "]\n")
                  .find(expected),
              std::string::npos)
        << generator;
  }
  EXPECT_NE(configErrorOf("resolution: 0.1\n" + bounds + "generators:\n  - {type: jungle}\n")
                .find("spec.yaml:4:12: generators[0].type: unknown world generator 'jungle'"),
            std::string::npos);
  EXPECT_NE(configErrorOf("resolution: 0.1\n" + bounds +
                          "generators:\n  - type: forest\n    densty: 0.1\n")
                .find("spec.yaml:5:13: generators[0].densty: world 'forest': unknown parameter "
                      "'densty' (did you mean 'density'?)"),
            std::string::npos);
  EXPECT_NE(configErrorOf("resolution: -0.1\n" + bounds + "generators:\n  - {type: empty}\n")
                .find("resolution: expected a number in [0.001, 100], got -0.1"),
            std::string::npos);
  EXPECT_NE(configErrorOf("resolution: 0.1\ngenerators:\n  - {type: empty}\n")
                .find("missing required key 'bounds'"),
            std::string::npos);
  EXPECT_NE(configErrorOf("resolution: 0.1\n" + bounds +
                          "generators:\n  - {type: forest, trunk_radius: [0.5, 0.1]}\n")
                .find("generators[0].trunk_radius: world 'forest': parameter 'trunk_radius': "
                      "expected [low, high]"),
            std::string::npos);
  EXPECT_NE(configErrorOf("resolution: 0.1\n" + bounds + "generators: []\nextra: 1\n")
                .find("expected at least one generator"),
            std::string::npos);
}

TEST(WorldTest, RobotRadiusIsAQueryTimeParameter) {
  const WorldSpec spec = specFromText(
      "resolution: 0.1\nbounds: {min: [0, 0, 0], max: [4, 4, 2]}\ngenerators:\n"
      "  - type: box_list\n    boxes: [{min: [2, 0, 0], max: [2.4, 4, 2]}]\n");
  const auto world = World::build(spec);
  // The nearest occupied voxel cube starts at x = 2, 0.45 m away.
  const Eigen::Vector3d point(1.55, 2.0, 1.0);
  EXPECT_NEAR(world->distance(point), 0.45, 1e-6);
  EXPECT_TRUE(world->isFree(point, 0.3));
  EXPECT_FALSE(world->isFree(point, 0.5));
  EXPECT_FALSE(world->isFree({-1.0, 2.0, 1.0}, 0.0));
}

TEST(WorldTest, SegmentFreeSaysWhetherAStraightLineIsOpenToTheBody) {
  // A wall across x = 2 .. 2.4 for y < 3; the strip y > 3 is open.
  const WorldSpec spec = specFromText(
      "resolution: 0.1\nbounds: {min: [0, 0, 0], max: [4, 4, 2]}\ngenerators:\n"
      "  - type: box_list\n    boxes: [{min: [2, 0, 0], max: [2.4, 3, 2]}]\n");
  const auto world = World::build(spec);
  EXPECT_FALSE(world->segmentFree({0.5, 1.0, 1.0}, {3.5, 1.0, 1.0}, 0.0));
  EXPECT_TRUE(world->segmentFree({0.5, 3.5, 1.0}, {3.5, 3.5, 1.0}, 0.25));
  // 0.5 m from the wall's end: free for a 0.25 m body, not for a 0.6 m one.
  EXPECT_FALSE(world->segmentFree({0.5, 3.5, 1.0}, {3.5, 3.5, 1.0}, 0.6));
  // Grazing the wall's corner diagonally: blocked once the body reaches it.
  EXPECT_FALSE(world->segmentFree({1.0, 2.0, 1.0}, {3.5, 3.4, 1.0}, 0.25));
  // Outside the map, and a NaN end, are not free; a zero-length segment is its point.
  EXPECT_FALSE(world->segmentFree({0.5, 3.5, 1.0}, {4.5, 3.5, 1.0}, 0.0));
  EXPECT_FALSE(world->segmentFree({0.5, 3.5, 1.0}, {NAN, 3.5, 1.0}, 0.0));
  EXPECT_TRUE(world->segmentFree({0.5, 3.5, 1.0}, {0.5, 3.5, 1.0}, 0.25));
  // A radius or tolerance that is NaN, negative or infinite is a caller's error, never "free".
  for (const double radius : {double(NAN), -1.0, double(INFINITY)}) {
    EXPECT_THROW(world->segmentFree({0.5, 1.0, 1.0}, {3.5, 1.0, 1.0}, radius), InvalidArgument);
  }
  EXPECT_THROW(world->segmentFree({0.5, 1.0, 1.0}, {3.5, 1.0, 1.0}, 0.2, NAN), InvalidArgument);
  // A coordinate that is not finite has no distance: NaN, not the clamped field's value.
  for (const double bad : {double(NAN), double(INFINITY), -double(INFINITY)}) {
    const Eigen::Vector3d p(1.0, bad, 1.0);
    EXPECT_TRUE(std::isnan(world->distance(p))) << bad;
    EXPECT_TRUE(std::isnan(world->clearance(p))) << bad;
    EXPECT_FALSE(world->isFree(p, 0.0)) << bad;
  }
  EXPECT_FALSE(std::isnan(world->distance({-5.0, 1.0, 1.0})));  // outside, finite: clamped
  // Against the exact distance to the wall's box along a dense walk.
  const auto exact = [](const Eigen::Vector3d& p) {
    const Eigen::Vector3d low(2.0, 0.0, 0.0), high(2.4, 3.0, 2.0);
    return (low - p).cwiseMax(p - high).cwiseMax(0.0).norm();
  };
  Rng rng(5);
  int free = 0;
  for (int i = 0; i < 300; ++i) {
    const Eigen::Vector3d a(rng.uniform(0.3, 3.7), rng.uniform(0.3, 3.7), 1.0);
    const Eigen::Vector3d b(rng.uniform(0.3, 3.7), rng.uniform(0.3, 3.7), 1.0);
    bool dense_free = true;
    for (int k = 0; k <= 2000; ++k) dense_free &= exact(a + (b - a) * (k / 2000.0)) >= 0.2 - 1e-9;
    // Tracing never calls a segment free that comes closer than radius - tolerance.
    if (world->segmentFree(a, b, 0.21, 0.01)) {
      EXPECT_TRUE(dense_free) << i;
      ++free;
    }
  }
  EXPECT_GT(free, 50);  // the check saw free segments, not only blocked ones
}

}  // namespace
}  // namespace kinolab
