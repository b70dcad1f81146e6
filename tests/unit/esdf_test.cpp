#include "kinolab/world/esdf.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <span>
#include <string>

#include "kinolab/core/error.hpp"
#include "kinolab/core/random.hpp"
#include "support/arrays.hpp"

namespace kinolab {
namespace {

VoxelGrid randomGrid(const Eigen::Vector3i& dims, double occupancy, std::uint64_t seed,
                     double resolution = 1.0) {
  VoxelGrid grid(Box{Eigen::Vector3d::Zero(), dims.cast<double>() * resolution}, resolution);
  Rng rng(seed);
  for (std::size_t i = 0; i < grid.size(); ++i) grid.setOccupied(i, rng.uniform01() < occupancy);
  return grid;
}

/// The signed distance by definition: from the voxel's centre to the nearest cube of a voxel
/// of the other kind, in voxels.
double bruteForce(const VoxelGrid& grid, const VoxelIndex& voxel) {
  const bool inside = grid.occupied(voxel);
  double best = std::numeric_limits<double>::infinity();
  const Eigen::Vector3i& dims = grid.dims();
  for (int x = 0; x < dims.x(); ++x) {
    for (int y = 0; y < dims.y(); ++y) {
      for (int z = 0; z < dims.z(); ++z) {
        if (grid.occupied(grid.index(x, y, z)) == inside) continue;
        const Eigen::Vector3d offset =
            ((Eigen::Vector3i(x, y, z) - voxel).cast<double>().cwiseAbs().array() - 0.5)
                .max(0.0)
                .matrix();
        best = std::min(best, offset.squaredNorm());
      }
    }
  }
  return inside ? -std::sqrt(best) : std::sqrt(best);
}

struct EsdfCase {
  Eigen::Vector3i dims;
  double occupancy;
};

class EsdfBruteForceTest : public ::testing::TestWithParam<EsdfCase> {};

TEST_P(EsdfBruteForceTest, MatchesBruteForceWithinATenThousandthOfAVoxel) {
  const EsdfCase c = GetParam();
  for (std::uint64_t seed = 1; seed <= 3; ++seed) {
    const VoxelGrid grid = randomGrid(c.dims, c.occupancy, seed);
    const Esdf esdf(grid);
    double worst = 0.0;
    for (int x = 0; x < c.dims.x(); ++x) {
      for (int y = 0; y < c.dims.y(); ++y) {
        for (int z = 0; z < c.dims.z(); ++z) {
          const VoxelIndex voxel(x, y, z);
          const double expected = bruteForce(grid, voxel);
          if (std::isinf(expected)) continue;  // a one-kind grid; tested separately
          worst = std::max(worst, std::abs(esdf.voxelDistance(grid.index(voxel)) - expected));
        }
      }
    }
    EXPECT_LT(worst, 1e-4) << "dims " << c.dims.transpose() << " occupancy " << c.occupancy
                           << " seed " << seed;
  }
}

INSTANTIATE_TEST_SUITE_P(RandomGrids, EsdfBruteForceTest,
                         ::testing::Values(EsdfCase{{1, 1, 7}, 0.3}, EsdfCase{{5, 6, 7}, 0.1},
                                           EsdfCase{{16, 9, 4}, 0.02}, EsdfCase{{12, 12, 12}, 0.05},
                                           EsdfCase{{12, 12, 12}, 0.3},
                                           EsdfCase{{20, 17, 11}, 0.01}, EsdfCase{{33, 21, 5}, 0.5},
                                           EsdfCase{{24, 24, 24}, 0.9},
                                           EsdfCase{{40, 3, 19}, 0.002}));

/// The strided passes take four adjacent lines at a time by a joint scan outwards and fall
/// back to the envelope, line by line, when an entry lies more than 16 voxels from the other
/// kind: grids long along x (pass 3) or y (pass 2) with dense ends and an empty middle mix both
/// within one group of lines, next to lines dense throughout.
TEST(EsdfTest, LinesWithFarEntriesBesideNearOnesAreExact) {
  for (const Eigen::Vector3i& dims : {Eigen::Vector3i(80, 6, 5), Eigen::Vector3i(6, 80, 5)}) {
    const int along = dims.x() > dims.y() ? 0 : 1;
    VoxelGrid grid = randomGrid(dims, 0.0, 1, 0.1);
    Rng rng(5);
    for (int x = 0; x < dims.x(); ++x) {
      for (int y = 0; y < dims.y(); ++y) {
        for (int z = 0; z < dims.z(); ++z) {
          const int position = along == 0 ? x : y;
          const int across = along == 0 ? y : x;
          const bool dense = position < 12 || position >= 68 || across == 2;
          if (dense && rng.uniform01() < 0.3) grid.setOccupied(grid.index(x, y, z), true);
        }
      }
    }
    const Esdf esdf(grid);
    double worst = 0.0;
    for (int x = 0; x < dims.x(); ++x) {
      for (int y = 0; y < dims.y(); ++y) {
        for (int z = 0; z < dims.z(); ++z) {
          const VoxelIndex voxel(x, y, z);
          const double expected = bruteForce(grid, voxel) * grid.resolution();
          worst = std::max(worst, std::abs(esdf.voxelDistance(grid.index(voxel)) - expected));
        }
      }
    }
    EXPECT_LT(worst, 1e-5) << "dims " << dims.transpose();
    // The incremental field's passes go line by line, in another order.
    EXPECT_EQ(asVector(IncrementalEsdf(grid).esdf().values()), asVector(esdf.values()))
        << "dims " << dims.transpose();
  }
}

/// A short line (12 voxels) with no site beside a long one whose sites are over 16,384 voxels away
/// (a squared distance above 2^30 quarter voxels): the four-line scan must leave such lines to the
/// envelope rather than offer a capped sum as a site.
TEST(EsdfTest, DistancesBeyondSixteenThousandVoxelsAreExact) {
  const Eigen::Vector3i dims(20000, 12, 1);
  const double resolution = 0.01;
  VoxelGrid grid(Box{Eigen::Vector3d::Zero(), dims.cast<double>() * resolution}, resolution);
  grid.setOccupied(grid.index(0, 0, 0), true);
  const Esdf esdf(grid);
  double worst = 0.0;
  for (int x = 0; x < dims.x(); ++x) {
    for (int y = 0; y < dims.y(); ++y) {
      if (x == 0 && y == 0) continue;
      const double expected =
          std::hypot(std::max(x - 0.5, 0.0), std::max(y - 0.5, 0.0)) * resolution;
      const double value = esdf.voxelDistance(grid.index(x, y, 0));
      worst = std::max(worst, std::abs(value - expected) / expected);
    }
  }
  EXPECT_LT(worst, 1e-6);
}

/// Random edits of a grid's occupancy, as a vehicle's window sees them: a few voxels
/// appearing or vanishing, a box of them at once, everything cleared and filled again.
TEST(IncrementalEsdfTest, EveryUpdateEqualsAFullBuildBitForBit) {
  for (const auto& [dims, density] :
       {std::pair{Eigen::Vector3i(23, 17, 9), 0.05}, std::pair{Eigen::Vector3i(1, 40, 6), 0.2},
        std::pair{Eigen::Vector3i(30, 30, 30), 0.002},
        // Long sparse lines of one axis each (an obstacle at a line's far end is the nearest),
        // and a grid one voxel thick.
        std::pair{Eigen::Vector3i(3, 70, 2), 0.01}, std::pair{Eigen::Vector3i(2, 3, 90), 0.01},
        std::pair{Eigen::Vector3i(40, 25, 1), 0.02}}) {
    VoxelGrid grid = randomGrid(dims, density, 7, 0.1);
    IncrementalEsdf incremental(grid);
    Rng rng(11);
    for (int step = 0; step < 40; ++step) {
      std::vector<std::uint8_t> occupancy = asVector(grid.occupancy());
      if (step == 20) {
        std::fill(occupancy.begin(), occupancy.end(), 0);  // all free: the cap everywhere
      } else if (step == 21) {
        std::fill(occupancy.begin(), occupancy.end(), 1);  // all occupied
      } else if (step % 5 == 4) {
        const VoxelIndex low(static_cast<int>(rng.uniformInt(0, dims.x() - 1)),
                             static_cast<int>(rng.uniformInt(0, dims.y() - 1)),
                             static_cast<int>(rng.uniformInt(0, dims.z() - 1)));
        const std::uint8_t value = rng.uniform01() < 0.5 ? 1 : 0;
        for (int x = low.x(); x < std::min(dims.x(), low.x() + 4); ++x) {
          for (int y = low.y(); y < std::min(dims.y(), low.y() + 3); ++y) {
            for (int z = low.z(); z < std::min(dims.z(), low.z() + 2); ++z) {
              occupancy[grid.index(x, y, z)] = value;
            }
          }
        }
      } else {
        for (int k = 0; k < 1 + step % 3; ++k) {
          const auto i = static_cast<std::size_t>(
              rng.uniformInt(0, static_cast<std::int64_t>(grid.size()) - 1));
          occupancy[i] = occupancy[i] ? 0 : 1;
        }
      }
      std::ranges::copy(occupancy, grid.mutableOccupancy().begin());
      incremental.update(occupancy);
      const Esdf full(grid);
      ASSERT_EQ(asVector(incremental.esdf().values()), asVector(full.values()))
          << "dims " << dims.transpose() << " step " << step;
      ASSERT_EQ(asVector(incremental.grid().occupancy()), asVector(grid.occupancy()));
    }
  }
}

TEST(EsdfTest, AnyNumberOfThreadsBuildsTheSameFieldBitForBit) {
  // Shapes whose lines do not split evenly (pass 3's blocks of 16 lines end mid-slab), more
  // threads than x-slabs, and the brute force on the small one.
  for (const auto& [dims, density] :
       {std::pair{Eigen::Vector3i(37, 29, 11), 0.03}, std::pair{Eigen::Vector3i(3, 50, 7), 0.1},
        std::pair{Eigen::Vector3i(9, 8, 5), 0.2}}) {
    const VoxelGrid grid = randomGrid(dims, density, 5, 0.1);
    const Esdf one(grid, 1);
    for (const int threads : {2, 3, 4, 7}) {
      EXPECT_EQ(asVector(Esdf(grid, threads).values()), asVector(one.values()))
          << "dims " << dims.transpose() << ", " << threads << " threads";
    }
    if (grid.size() < 1000) {
      const Esdf three(grid, 3);
      for (std::size_t i = 0; i < grid.size(); ++i) {
        const VoxelIndex voxel(static_cast<int>(i / (dims.y() * dims.z())),
                               static_cast<int>(i / dims.z() % dims.y()),
                               static_cast<int>(i % dims.z()));
        EXPECT_NEAR(three.voxelDistance(i), 0.1 * bruteForce(grid, voxel), 1e-5);
      }
    }
  }
  EXPECT_THROW(Esdf(randomGrid({4, 4, 4}, 0.1, 1), -1), InvalidArgument);
}

TEST(IncrementalEsdfTest, AnUpdateRecomputesOnlyTheLinesItReaches) {
  VoxelGrid grid = randomGrid({60, 60, 20}, 0.01, 3, 0.1);
  IncrementalEsdf incremental(grid);
  const std::size_t full = incremental.linesRecomputed();
  EXPECT_EQ(full, 2u * (60 * 60 + 60 * 20 + 60 * 20));
  EXPECT_EQ(incremental.update(asVector(grid.occupancy())), 0u);  // nothing changed: no work
  EXPECT_EQ(incremental.linesRecomputed(), full);
  std::vector<std::uint8_t> occupancy = asVector(grid.occupancy());
  const std::size_t voxel = grid.index(30, 30, 10);
  occupancy[voxel] = occupancy[voxel] ? 0 : 1;
  EXPECT_EQ(incremental.update(occupancy), 1u);
  const std::size_t work = incremental.linesRecomputed() - full;
  EXPECT_GT(work, 0u);
  EXPECT_LT(work, full / 4) << "one voxel in a 1 % grid should reach a few lines";
  std::ranges::copy(occupancy, grid.mutableOccupancy().begin());
  EXPECT_EQ(asVector(incremental.esdf().values()), asVector(Esdf(grid).values()));
}

TEST(IncrementalEsdfTest, ANewObstacleInFreeSpaceTransformsOnlyItsXLines) {
  // One voxel turns occupied far from every other: the distances to the occupied cubes only
  // shrink, so their y-lines and columns are lowered from the change alone; the distances to
  // the free cubes grow only at that voxel, which is found anew by its own scan. Only the two
  // x-lines of pass 1 (one a field) are transformed.
  VoxelGrid grid(Box{Eigen::Vector3d::Zero(), Eigen::Vector3d(4.0, 3.0, 2.0)}, 0.1);
  grid.setOccupied({2, 2, 2}, true);
  IncrementalEsdf incremental(grid);
  const std::size_t built = incremental.linesRecomputed();
  grid.setOccupied({30, 20, 12}, true);
  ASSERT_EQ(incremental.update(asVector(grid.occupancy())), 1u);
  EXPECT_EQ(incremental.linesRecomputed() - built, 2u);
  EXPECT_EQ(asVector(incremental.esdf().values()), asVector(Esdf(grid).values()));
  // And back: the outside distances grow wherever the voxel was their minimum, too many
  // entries to scan, so its lines are transformed anew, and the field is the first one again.
  grid.setOccupied({30, 20, 12}, false);
  ASSERT_EQ(incremental.update(asVector(grid.occupancy())), 1u);
  EXPECT_GT(incremental.linesRecomputed() - built, 2u + 2u);
  EXPECT_EQ(asVector(incremental.esdf().values()), asVector(Esdf(grid).values()));
}

TEST(EsdfTest, AGridAtTheTransformsLimitIsExactAndOneBeyondIsRefused) {
  // Squared distances in quarter voxels are int32: a line of 23,000 voxels, (2 n)^2 = 2.116e9,
  // still fits, and its far end is exact; 23,200 would overflow and is refused by name.
  VoxelGrid line(Box{Eigen::Vector3d::Zero(), Eigen::Vector3d(1.0, 1.0, 23000.0)}, 1.0);
  line.setOccupied({0, 0, 0}, true);
  const Esdf esdf(line);
  EXPECT_NEAR(esdf.voxelDistance(line.index(0, 0, 22999)), 22998.5, 1e-2);
  EXPECT_NEAR(IncrementalEsdf(line).esdf().voxelDistance(line.index(0, 0, 22999)), 22998.5, 1e-2);
  const VoxelGrid longer(Box{Eigen::Vector3d::Zero(), Eigen::Vector3d(1.0, 1.0, 23200.0)}, 1.0);
  try {
    const Esdf refused(longer);
    FAIL() << "a grid beyond the transform was built";
  } catch (const InvalidArgument& error) {
    EXPECT_NE(std::string(error.what()).find("1 x 1 x 23200"), std::string::npos) << error.what();
  }
  EXPECT_THROW(IncrementalEsdf{longer}, InvalidArgument);
}

TEST(EsdfTest, SingleObstacleGivesTheEuclideanDistanceToItsCubeInMetres) {
  const double resolution = 0.25;
  VoxelGrid grid(Box{Eigen::Vector3d::Zero(), Eigen::Vector3d(5.0, 4.0, 3.0)}, resolution);
  const VoxelIndex obstacle(3, 7, 2);
  grid.setOccupied(obstacle, true);
  const Esdf esdf(grid);
  // Inside: half a voxel to the nearest free cube; outside: to the obstacle's cube.
  EXPECT_FLOAT_EQ(esdf.voxelDistance(grid.index(obstacle)), -0.5 * resolution);
  const VoxelIndex far(15, 0, 10);
  const Eigen::Vector3d offset = (far - obstacle).cast<double>().cwiseAbs().array() - 0.5;
  EXPECT_NEAR(esdf.voxelDistance(grid.index(far)), offset.norm() * resolution, 1e-5);
}

TEST(EsdfTest, GridWithoutObstaclesHoldsTheDiagonal) {
  const VoxelGrid grid(Box{Eigen::Vector3d::Zero(), Eigen::Vector3d(2.0, 3.0, 1.0)}, 0.5);
  const Esdf esdf(grid);
  for (float value : esdf.values()) EXPECT_FLOAT_EQ(value, std::sqrt(14.0));
  EXPECT_DOUBLE_EQ(esdf.maxDistance(), std::sqrt(14.0));
}

TEST(EsdfTest, TrilinearEqualsStoredValuesAtVoxelCentres) {
  const VoxelGrid grid = randomGrid({10, 8, 6}, 0.1, 42, 0.2);
  const Esdf esdf(grid);
  for (int x = 0; x < 10; ++x) {
    for (int y = 0; y < 8; ++y) {
      for (int z = 0; z < 6; ++z) {
        const Eigen::Vector3d c = grid.center({x, y, z});
        const double stored = esdf.voxelDistance(grid.index(x, y, z));
        EXPECT_NEAR(esdf.distance(c), stored, 1e-6);
        EXPECT_NEAR(esdf.nearestDistance(c + Eigen::Vector3d::Constant(0.04)), stored, 1e-6);
      }
    }
  }
}

TEST(EsdfTest, AnalyticGradientMatchesFiniteDifferences) {
  const VoxelGrid grid = randomGrid({14, 12, 10}, 0.05, 9, 0.1);
  const Esdf esdf(grid);
  Rng rng(5);
  const double h = 1e-6;
  int compared = 0;
  for (int trial = 0; trial < 2000; ++trial) {
    const Eigen::Vector3d p(rng.uniform(0.06, 1.34), rng.uniform(0.06, 1.14),
                            rng.uniform(0.06, 0.94));
    Eigen::Vector3d gradient;
    const double value = esdf.distanceWithGradient(p, &gradient);
    EXPECT_DOUBLE_EQ(value, esdf.distance(p));
    for (int axis = 0; axis < 3; ++axis) {
      // Skip points within h of a cell face, where the derivative jumps.
      const double scaled = p[axis] / 0.1 - 0.5;
      if (std::abs(scaled - std::round(scaled)) < 1e-4) continue;
      Eigen::Vector3d step = Eigen::Vector3d::Zero();
      step[axis] = h;
      const double numeric = (esdf.distance(p + step) - esdf.distance(p - step)) / (2 * h);
      EXPECT_NEAR(gradient[axis], numeric, 1e-5);
      ++compared;
    }
  }
  EXPECT_GT(compared, 5000);
}

TEST(EsdfTest, ACoordinateThatIsNotFiniteReadsInRangeAndGivesNaN) {
  // The index stays in range (the sanitizer build checks the read), and the answer is NaN:
  // a point with no position has no distance, never the clamped field's value.
  const VoxelGrid grid = randomGrid({10, 8, 6}, 0.1, 42, 0.2);
  const Esdf esdf(grid);
  for (const Eigen::Vector3d& bad :
       {Eigen::Vector3d(std::nan(""), 1.0, 0.3),
        Eigen::Vector3d(0.5, 1.0, -std::numeric_limits<double>::infinity()),
        Eigen::Vector3d(0.5, std::numeric_limits<double>::infinity(), 0.3)}) {
    EXPECT_TRUE(std::isnan(esdf.distance(bad)));
    EXPECT_TRUE(std::isfinite(esdf.nearestDistance(bad)));  // an in-range lookup, unchecked
    EXPECT_TRUE(std::isnan(esdf.clearance(bad)));
    Eigen::Vector3d gradient;
    EXPECT_TRUE(std::isnan(esdf.distanceWithGradient(bad, &gradient)));  // the value
  }
}

/// distances() and distancesWithGradients() find two points' cells at once in SSE2 lanes and
/// interpolate in chunks of sixteen: every value must be the single query's, bit for bit,
/// for every count (chunks cut anywhere, an odd point alone), on both layouts, a grid one voxel
/// thick, and points outside the map, on its bounds or without a position.
TEST(EsdfTest, ManyPointsAtOnceGiveTheSingleQueriesValuesBitForBit) {
  const VoxelGrid dense = randomGrid({19, 14, 11}, 0.08, 4, 0.1);
  const VoxelGrid flat = randomGrid({9, 12, 1}, 0.2, 5, 0.1);
  const Esdf fields[] = {Esdf(dense), Esdf::truncated(dense, 0.35), Esdf(flat)};
  Rng rng(9);
  std::vector<Eigen::Vector3d> points(1003);
  for (auto& p : points) {
    p = {rng.uniform(-0.3, 2.2), rng.uniform(-0.3, 1.7), rng.uniform(-0.3, 1.4)};
  }
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  points[3] = {nan, 0.5, 0.5};
  points[4] = {0.5, inf, 0.5};
  points[5] = {0.5, 0.5, -inf};
  points[6] = {-0.0, 0.05, 1.1};   // the low side, a centre, the top of the dense grid
  points[7] = {1.9, 1.4, 1.1};     // the dense grid's far corner
  points[8] = {0.85, 0.65, 0.05};  // a centre
  points[9] = {1e300, -1e300, nan};
  const auto same = [](double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; };
  for (const Esdf& esdf : fields) {
    for (const std::size_t count : {0, 1, 2, 3, 15, 16, 17, 33, 1003}) {
      const std::span<const Eigen::Vector3d> some(points.data(), count);
      std::vector<double> distances(count);
      std::vector<double> plain(count);
      std::vector<Eigen::Vector3d> gradients(count);
      esdf.distancesWithGradients(some, distances, gradients);
      esdf.distances(some, plain);
      for (std::size_t i = 0; i < count; ++i) {
        Eigen::Vector3d gradient;
        const double expected = esdf.distanceWithGradient(points[i], &gradient);
        ASSERT_TRUE(same(distances[i], expected)) << "point " << i << " of " << count;
        ASSERT_TRUE(same(plain[i], esdf.distance(points[i]))) << "point " << i << " of " << count;
        for (int axis = 0; axis < 3; ++axis) {
          ASSERT_TRUE(same(gradients[i][axis], gradient[axis]))
              << "point " << i << " axis " << axis;
        }
      }
    }
  }
  std::vector<double> two(2);
  EXPECT_THROW(fields[0].distances(points, two), InvalidArgument);
  std::vector<Eigen::Vector3d> one(1);
  EXPECT_THROW(fields[0].distancesWithGradients(std::span(points).first(2), two, one),
               InvalidArgument);
}

TEST(EsdfTest, PointsOutsideTheMapTakeTheValueOfTheNearestPointInside) {
  const VoxelGrid grid = randomGrid({8, 8, 8}, 0.1, 3, 0.5);
  const Esdf esdf(grid);
  const Eigen::Vector3d inside(3.9, 2.0, 0.25);  // on the last x-centre plane (3.75) and beyond
  const Eigen::Vector3d outside(10.0, 2.0, -5.0);
  const Eigen::Vector3d projected(3.75, 2.0, 0.25);
  EXPECT_DOUBLE_EQ(esdf.distance(outside), esdf.distance(projected));
  EXPECT_DOUBLE_EQ(esdf.distance(inside), esdf.distance(projected));
  Eigen::Vector3d gradient;
  esdf.distanceWithGradient(outside, &gradient);
  EXPECT_EQ(gradient.x(), 0.0);
  EXPECT_EQ(gradient.z(), 0.0);
}

}  // namespace
}  // namespace kinolab

namespace kinolab {
namespace {

/// The distance from `point` to the nearest occupied cube by definition (metres; 0 in one).
double pointToCubesBruteForce(const VoxelGrid& grid, const Eigen::Vector3d& point) {
  double best = std::numeric_limits<double>::infinity();
  const Eigen::Vector3i& dims = grid.dims();
  const double r = grid.resolution();
  for (int x = 0; x < dims.x(); ++x) {
    for (int y = 0; y < dims.y(); ++y) {
      for (int z = 0; z < dims.z(); ++z) {
        if (!grid.occupied(grid.index(x, y, z))) continue;
        const Eigen::Vector3d low = grid.origin() + Eigen::Vector3d(x, y, z) * r;
        const Eigen::Vector3d gap =
            (low - point).cwiseMax(point - low - Eigen::Vector3d::Constant(r)).cwiseMax(0.0);
        best = std::min(best, gap.norm());
      }
    }
  }
  return best;
}

TEST(EsdfTest, ExactDistanceInAMapWithoutObstaclesIsTheLimit) {
  // Every value is the cap (the diagonal): no cube anywhere, whatever the limit, at once.
  const Esdf esdf(randomGrid({30, 20, 10}, 0.0, 1, 0.2));
  for (const Eigen::Vector3d& point : {Eigen::Vector3d(0.1, 0.1, 0.1), Eigen::Vector3d(3, 2, 1)}) {
    EXPECT_EQ(esdf.exactDistance(point, 2.0), 2.0);
    EXPECT_EQ(esdf.exactDistance(point, esdf.maxDistance()), esdf.maxDistance());
    EXPECT_EQ(esdf.exactDistance(point, INFINITY), INFINITY);
  }
  // One occupied voxel in the far corner: found from the other end of the diagonal.
  VoxelGrid grid = randomGrid({30, 20, 10}, 0.0, 1, 0.2);
  grid.setOccupied(VoxelIndex(29, 19, 9), true);
  const Esdf one(grid);
  EXPECT_NEAR(one.exactDistance({0.0, 0.0, 0.0}, INFINITY), Eigen::Vector3d(5.8, 3.8, 1.8).norm(),
              1e-9);
}

TEST(EsdfTest, ExactDistanceIsTheDistanceToTheNearestCubeBelowTheLimit) {
  // Random points (inside and a little outside the map) on random grids at three
  // resolutions: below the limit the exact distance to the cubes, else the limit; and never
  // below clearance(), the lower bound it refines.
  for (const double resolution : {0.5, 0.25, 0.1}) {
    for (const double occupancy : {0.01, 0.05, 0.3}) {
      const VoxelGrid grid = randomGrid({14, 11, 9}, occupancy, 3, resolution);
      const Esdf esdf(grid);
      Rng rng(11);
      const Eigen::Vector3d size = grid.dims().cast<double>() * resolution;
      int below = 0;
      for (int i = 0; i < 300; ++i) {
        const auto point = drawLastFirst<Eigen::Vector3d>(  // the same on every compiler
            [&](int axis) { return rng.uniform(-0.1, 1.1) * size[axis]; });
        const double expected = pointToCubesBruteForce(grid, point);
        // The centres' bound never exceeds the distance (anywhere, outside the map too), and
        // every verdict agrees with the brute force.
        EXPECT_LE(esdf.centreBound(point), expected + 1e-6);
        for (const double threshold : {0.05, 0.25, 0.6}) {
          EXPECT_EQ(esdf.decided(point, esdf.clearance(point), threshold, threshold) >= threshold,
                    expected >= threshold)
              << threshold;
        }
        for (const double limit : {0.3, 1.0, 100.0}) {
          SCOPED_TRACE(::testing::Message()
                       << "resolution " << resolution << " occupancy " << occupancy << " point "
                       << point.transpose() << " limit " << limit);
          const double exact = esdf.exactDistance(point, limit);
          // Stopping at the first cube nearer than 0.3 m decides the same verdict at 0.3.
          const double early = esdf.exactDistance(point, limit, 0.3);
          EXPECT_EQ(early < 0.3, exact < 0.3);
          EXPECT_GE(early, exact);
          if (exact >= 0.3) {
            EXPECT_EQ(early, exact);
          }
          if (expected == 0.0) {
            EXPECT_EQ(exact, -0.5 * resolution);
            ++below;
          } else if (expected < limit) {
            EXPECT_NEAR(exact, expected, 1e-9);
            ++below;
          } else {
            EXPECT_EQ(exact, limit);
          }
          // Outside the cubes both are distances, and the exact one is at least the bound
          // (in a cube exactDistance() is -half a voxel, a flag, not a depth).
          const bool inside = (point.array() >= 0.0).all() && (point.array() <= size.array()).all();
          if (inside && expected > 0.0) {
            EXPECT_GE(exact + 1e-9, std::min(esdf.clearance(point), limit));
          }
        }
      }
      EXPECT_GT(below, 300);
    }
  }
}

/// A grid of `dims` with random voxels and boxes: a solid block (bricks deeper than any
/// truncation), an empty region (tiles without obstacles), thin walls.
VoxelGrid structuredGrid(const Eigen::Vector3i& dims, double resolution, GridLayout layout,
                         std::uint64_t seed) {
  VoxelGrid grid(Box{Eigen::Vector3d::Zero(), dims.cast<double>() * resolution}, resolution,
                 layout);
  Rng rng(seed);
  const Eigen::Vector3d size = dims.cast<double>() * resolution;
  grid.fillBox(Eigen::Vector3d(0.1, 0.1, 0.0).cwiseProduct(size),
               Eigen::Vector3d(0.35, 0.3, 0.8).cwiseProduct(size));
  grid.fillBox(Eigen::Vector3d(0.5, 0.0, 0.0).cwiseProduct(size),
               Eigen::Vector3d(0.52, 0.6, 0.5).cwiseProduct(size));
  for (int i = 0; i < 400; ++i) {
    const VoxelIndex v(static_cast<int>(rng.uniform01() * dims.x() * 0.7),
                       static_cast<int>(rng.uniform01() * dims.y()),
                       static_cast<int>(rng.uniform01() * dims.z()));
    grid.setOccupied(v, true);
  }
  grid.compactBricks();
  return grid;
}

TEST(EsdfTest, ATruncatedFieldIsTheExactFieldClampedAtItsTruncationBitForBit) {
  // Several tiles (16 bricks of 8 voxels a side), sizes that are not whole bricks, both grid
  // layouts, one and two threads.
  for (const Eigen::Vector3i& dims :
       {Eigen::Vector3i(300, 140, 21), Eigen::Vector3i(37, 260, 9), Eigen::Vector3i(20, 20, 1)}) {
    for (const double truncation : {0.3, 1.0}) {
      const VoxelGrid dense = structuredGrid(dims, 0.1, GridLayout::kDense, 5);
      const VoxelGrid bricked = structuredGrid(dims, 0.1, GridLayout::kBricked, 5);
      const Esdf exact(dense);
      const auto limit = static_cast<float>(truncation);
      for (const int threads : {1, 2}) {
        for (const VoxelGrid* grid : {&dense, &bricked}) {
          SCOPED_TRACE(::testing::Message() << dims.transpose() << " truncation " << truncation
                                            << " threads " << threads);
          const Esdf truncated = Esdf::truncated(*grid, truncation, threads);
          EXPECT_EQ(truncated.truncation(), truncation);
          std::size_t differ = 0;
          for (std::size_t i = 0; i < dense.size(); ++i) {
            const float expected = std::clamp(exact.voxelDistance(i), -limit, limit);
            differ += truncated.voxelDistance(i) != expected ||
                      truncated.voxelDistance(dense.voxel(i)) != expected;
          }
          EXPECT_EQ(differ, 0u);
          // Values of their own for exactly the bricks with a value strictly between -T and T
          // (or deeper than T but cut by the grid's end, whose voxels beyond read +T).
          const Eigen::Vector3i bricks = (dims.array() + 7) / 8;
          std::size_t needed = 0;
          for (int bx = 0; bx < bricks.x(); ++bx) {
            for (int by = 0; by < bricks.y(); ++by) {
              for (int bz = 0; bz < bricks.z(); ++bz) {
                bool inside = false;
                bool all_deep = true;
                const VoxelIndex first = VoxelIndex(bx, by, bz) * 8;
                const VoxelIndex end = (first.array() + 8).min(dims.array());
                for (int x = first.x(); x < end.x(); ++x) {
                  for (int y = first.y(); y < end.y(); ++y) {
                    for (int z = first.z(); z < end.z(); ++z) {
                      const float value = exact.voxelDistance(VoxelIndex(x, y, z));
                      inside = inside || std::abs(value) < limit;
                      all_deep = all_deep && value <= -limit;
                    }
                  }
                }
                const bool cut = (end - first).minCoeff() < 8;
                needed += inside || (all_deep && cut) ? 1 : 0;
              }
            }
          }
          EXPECT_EQ(truncated.allocatedBricks(), needed);
          EXPECT_THROW((void)truncated.values(), InvalidArgument);
        }
      }
    }
  }
  EXPECT_THROW((void)Esdf::truncated(randomGrid({4, 4, 4}, 0.1, 1), 0.0), InvalidArgument);
  EXPECT_THROW((void)Esdf::truncated(randomGrid({4, 4, 4}, 0.1, 1), INFINITY), InvalidArgument);
}

TEST(EsdfTest, ATruncatedFieldGivesTheDenseVerdictsAndProvenBoundsUpToItsTruncation) {
  // Random points on random and structured grids: every query of the truncated field is the
  // dense field's where it can be (distances below T) and a lower bound of the distance
  // elsewhere; verdicts at thresholds up to T are the same.
  const double truncation = 0.5;
  for (int round = 0; round < 4; ++round) {
    const VoxelGrid grid = round < 2
                               ? randomGrid({40, 33, 17}, round == 0 ? 0.002 : 0.02, 7 + round, 0.1)
                               : structuredGrid({60, 50, 20}, 0.1, GridLayout::kBricked, round);
    VoxelGrid dense_grid(grid.bounds(), grid.resolution());
    grid.forEachOccupied([&](const VoxelIndex& v) { dense_grid.setOccupied(v, true); });
    const Esdf dense(dense_grid);
    const Esdf sparse = Esdf::truncated(grid, truncation);
    Rng rng(17 + round);
    const Eigen::Vector3d size = grid.dims().cast<double>() * grid.resolution();
    int exact_below = 0;
    for (int i = 0; i < 3000; ++i) {
      const auto point = drawLastFirst<Eigen::Vector3d>(
          [&](int axis) { return rng.uniform(-0.05, 1.05) * size[axis]; });
      SCOPED_TRACE(::testing::Message() << "round " << round << " point " << point.transpose());
      const double truth = dense.exactDistance(point, 100.0);
      const double clearance = sparse.clearance(point);
      if (clearance >= 0.0) {
        EXPECT_LE(clearance, truth + 1e-9);
      }
      const double centres = sparse.centreBound(point);
      if (centres >= 0.0) {
        EXPECT_LE(centres, truth + 1e-6);
      }
      for (const double threshold : {0.0, 0.05, 0.2, 0.45, truncation}) {
        EXPECT_EQ(sparse.decided(point, clearance, threshold, threshold) >= threshold,
                  dense.decided(point, dense.clearance(point), threshold, threshold) >= threshold)
            << threshold;
      }
      for (const double limit : {0.3, 2.0}) {
        const double exact = sparse.exactDistance(point, limit);
        const double expected = dense.exactDistance(point, limit);
        if (expected < std::min(limit, truncation)) {
          EXPECT_EQ(exact, expected) << limit;
          ++exact_below;
        } else {
          // A lower bound of the distance, and at least what the verdicts need.
          EXPECT_LE(exact, truth + 1e-9) << limit;
          EXPECT_GE(exact, std::min(limit, truncation)) << limit;
        }
      }
    }
    EXPECT_GT(exact_below, 100);
  }
}

TEST(EsdfTest, ACubeAtExactlyTheThresholdDoesNotHideANearerOne) {
  // One cube 0.3 m straight along y from the point, one 0.283 m away diagonally; the
  // threshold 3 * 0.1 rounds to just above 0.3. Stopping at the first cube "nearer than the
  // threshold" took the one at 0.3 and called the point free at it (found by a review).
  for (const GridLayout layout : {GridLayout::kDense, GridLayout::kBricked}) {
    VoxelGrid grid(Box{Eigen::Vector3d::Zero(), Eigen::Vector3d(2, 2, 0.4)}, 0.1, layout);
    grid.setOccupied(VoxelIndex(8, 13, 1), true);
    grid.setOccupied(VoxelIndex(5, 7, 1), true);
    const Esdf esdf = layout == GridLayout::kDense ? Esdf(grid) : Esdf::truncated(grid, 1.0);
    const Eigen::Vector3d point(0.8, 1.0, 0.15);
    const double threshold = 3 * 0.1;
    EXPECT_LT(esdf.decided(point, esdf.clearance(point), threshold, threshold), threshold);
    EXPECT_NEAR(esdf.exactDistance(point, 1.0), std::sqrt(0.08), 1e-12);
  }
}

TEST(EsdfTest, AnExactDistanceRunIsExactDistanceBitForBitWithLessWork) {
  // Runs of points a quarter voxel apart (a trajectory's samples) wandering through random and
  // structured grids, leaving them now and then, on dense and truncated fields and at limits
  // below and above the distances found.
  for (int round = 0; round < 4; ++round) {
    const bool structured = round >= 2;
    const VoxelGrid grid = structured ? structuredGrid({48, 40, 16}, 0.1, GridLayout::kDense, round)
                                      : randomGrid({30, 26, 12}, round == 0 ? 0.01 : 0.1, 5, 0.1);
    const Esdf dense(grid);
    const Esdf truncated = Esdf::truncated(grid, 0.4);
    const Eigen::Vector3d size = grid.dims().cast<double>() * grid.resolution();
    for (const Esdf* field : {&dense, &truncated}) {
      for (const double limit : {0.25, std::min(field->maxDistance(), field->truncation())}) {
        SCOPED_TRACE(::testing::Message() << "round " << round << " truncated "
                                          << (field == &truncated) << " limit " << limit);
        ExactDistanceRun run(*field, limit);
        Rng rng(31 + round);
        Eigen::Vector3d point = 0.5 * size;
        Eigen::Vector3d step = Eigen::Vector3d::UnitX() * 0.025;
        int points = 0;
        int inside = 0;
        for (int i = 0; i < 4000; ++i) {
          if (i % 200 == 0) {  // a new run somewhere, a few just outside the grid
            point = drawLastFirst<Eigen::Vector3d>(
                [&](int axis) { return rng.uniform(-0.05, 1.05) * size[axis]; });
            step = drawLastFirst<Eigen::Vector3d>([&](int) {
                     return rng.uniform(-1.0, 1.0);
                   }).normalized() *
                   0.025;
          }
          point += step;
          ++points;
          const double expected = field->exactDistance(point, limit);
          ASSERT_EQ(run(point), expected) << point.transpose();
          inside += expected < limit;
        }
        EXPECT_GT(inside, 300);  // enough points with a cube nearer than the limit
        // A block's cubes are gathered once for its run of points.
        EXPECT_LT(run.gathers(), static_cast<std::size_t>(points) / 4);
      }
    }
  }
}

/// Over a floor and beside a solid pillar, a gather keeps only the cubes that can be nearest
/// (those under the block, the pillar's face towards it), not every first cube of a column in
/// reach, and the distances stay exactDistance()'s bit for bit.
TEST(EsdfTest, AnExactDistanceRunKeepsNoCubeThatAnotherIsNeverFartherThan) {
  const Eigen::Vector3i dims(40, 40, 30);
  VoxelGrid grid(Box{Eigen::Vector3d::Zero(), dims.cast<double>() * 0.1}, 0.1);
  for (int x = 0; x < dims.x(); ++x)
    for (int y = 0; y < dims.y(); ++y) grid.setOccupied(grid.index(x, y, 0), true);
  for (const Esdf& field : {Esdf(grid), Esdf::truncated(grid, 2.0)}) {
    ExactDistanceRun run(field, 2.0);
    for (double x = 1.01; x < 3.0; x += 0.025) {  // 1.5 m above the floor, 14 voxels clear
      const Eigen::Vector3d point(x, 2.02, 1.5);
      ASSERT_EQ(run(point), field.exactDistance(point, 2.0)) << point.transpose();
    }
    ASSERT_GT(run.gathers(), 0u);
    // A block has kBlock^2 floor cubes under it; a column's first cube alone would keep every
    // floor cube within reach (hundreds).
    constexpr auto kUnder =
        static_cast<std::size_t>(ExactDistanceRun::kBlock * ExactDistanceRun::kBlock);
    EXPECT_EQ(run.cubesGathered(), kUnder * run.gathers());
    // A brick's occupancy is read once while cached, not once a gather: at most the grid's
    // 5 x 5 x 4 bricks (each of the gathers meets dozens).
    EXPECT_LE(run.bricksRead(), 100u);
  }
  // A solid pillar of 6 x 6 voxels: from points level with its middle, beside it along x, only
  // the face's cubes towards the block remain (one column of the face's 6 per height of the
  // block, and its edges), with the floor's cubes below the block.
  for (int x = 20; x < 26; ++x)
    for (int y = 17; y < 23; ++y)
      for (int z = 1; z < dims.z(); ++z) grid.setOccupied(grid.index(x, y, z), true);
  const Esdf field(grid);
  ExactDistanceRun run(field, 2.0);
  for (double x = 0.5; x < 1.9; x += 0.025) {
    const Eigen::Vector3d point(x, 2.02, 1.5);
    ASSERT_EQ(run(point), field.exactDistance(point, 2.0)) << point.transpose();
  }
  EXPECT_LE(run.cubesGathered(), 60 * run.gathers());
}

TEST(EsdfTest, AnExactDistanceRunAmongBoxesIsExactDistanceBitForBit) {
  // Boxes of every shape (slabs along each axis, pillars, blocks; most bricks they fill are the
  // same along one axis or more, and a gather reads only their layer facing the block) in grids
  // whose sides are not whole bricks, so that bricks cut by the grid's end are uniform too.
  for (int round = 0; round < 3; ++round) {
    const Eigen::Vector3i dims =
        round == 0 ? Eigen::Vector3i(37, 29, 19)
                   : (round == 1 ? Eigen::Vector3i(45, 22, 27) : Eigen::Vector3i(30, 30, 13));
    VoxelGrid grid(Box{Eigen::Vector3d::Zero(), dims.cast<double>() * 0.1}, 0.1);
    Rng rng(70 + round);
    const Eigen::Vector3d size = dims.cast<double>() * 0.1;
    for (int box = 0; box < 14; ++box) {
      Eigen::Vector3d low;
      Eigen::Vector3d high;
      for (int axis = 0; axis < 3; ++axis) {
        // Thin along one axis (a wall or floor), long along another, anything along the third.
        const double side = axis == box % 3 ? rng.uniform(0.05, 0.5) : rng.uniform(0.3, 2.5);
        low[axis] = rng.uniform(-0.3, size[axis]);
        high[axis] = low[axis] + side;
      }
      grid.fillBox(low, high);
    }
    const Esdf dense(grid);
    const Esdf truncated = Esdf::truncated(grid, 0.5);
    for (const Esdf* field : {&dense, &truncated}) {
      const double limit = std::min(field->maxDistance(), field->truncation());
      SCOPED_TRACE(::testing::Message()
                   << "round " << round << " truncated " << (field == &truncated));
      ExactDistanceRun run(*field, limit);
      Eigen::Vector3d point = 0.5 * size;
      Eigen::Vector3d step = Eigen::Vector3d::Zero();
      int inside = 0;
      for (int i = 0; i < 6000; ++i) {
        if (i % 150 == 0) {
          point = drawLastFirst<Eigen::Vector3d>(
              [&](int axis) { return rng.uniform(0.0, 1.0) * size[axis]; });
          step = drawLastFirst<Eigen::Vector3d>([&](int) {
                   return rng.uniform(-1.0, 1.0);
                 }).normalized() *
                 0.025;
        }
        point += step;
        const double expected = field->exactDistance(point, limit);
        ASSERT_EQ(run(point), expected) << point.transpose();
        inside += expected < limit;
      }
      EXPECT_GT(inside, 1000);
    }
  }
}

}  // namespace
}  // namespace kinolab
