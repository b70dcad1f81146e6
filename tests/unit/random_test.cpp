#include "kinolab/core/random.hpp"

#include <gtest/gtest.h>

#include <array>
#include <cmath>

namespace kinolab {
namespace {

TEST(RngTest, SameSeedSameStreamOtherSeedOtherStream) {
  Rng a(123);
  Rng b(123);
  Rng c(124);
  int differences = 0;
  for (int i = 0; i < 1000; ++i) {
    const std::uint64_t x = a.nextU64();
    EXPECT_EQ(x, b.nextU64());
    differences += x != c.nextU64();
  }
  EXPECT_EQ(differences, 1000);
}

TEST(RngTest, DerivedStreamsDependOnNameAndIndex) {
  EXPECT_EQ(Rng::derive(1, "world", 2).nextU64(), Rng::derive(1, "world", 2).nextU64());
  EXPECT_NE(Rng::derive(1, "world", 2).nextU64(), Rng::derive(1, "world", 3).nextU64());
  EXPECT_NE(Rng::derive(1, "world", 2).nextU64(), Rng::derive(1, "query", 2).nextU64());
  EXPECT_NE(Rng::derive(1, "world", 2).nextU64(), Rng::derive(2, "world", 2).nextU64());
}

TEST(RngTest, DistributionsHaveTheirRangesAndMoments) {
  Rng rng(9);
  const int n = 200000;
  double sum = 0.0;
  double sum_squares = 0.0;
  int histogram[5] = {0, 0, 0, 0, 0};
  for (int i = 0; i < n; ++i) {
    const double u = rng.uniform(-2.0, 3.0);
    ASSERT_GE(u, -2.0);
    ASSERT_LT(u, 3.0);
    const std::int64_t k = rng.uniformInt(-1, 3);
    ASSERT_GE(k, -1);
    ASSERT_LE(k, 3);
    ++histogram[k + 1];
    const double g = rng.normal();
    sum += g;
    sum_squares += g * g;
  }
  EXPECT_NEAR(sum / n, 0.0, 0.01);
  EXPECT_NEAR(sum_squares / n, 1.0, 0.02);
  for (int count : histogram) EXPECT_NEAR(count, n / 5, n / 100);
}

TEST(RngTest, DrawsIntoAVectorGoLastCoordinateFirst) {
  Rng a(7);
  Rng b(7);
  const auto v = drawLastFirst<std::array<double, 3>>([&](int) { return a.uniform01(); });
  const double z = b.uniform01();
  const double y = b.uniform01();
  const double x = b.uniform01();
  EXPECT_EQ(v[0], x);
  EXPECT_EQ(v[1], y);
  EXPECT_EQ(v[2], z);
}

}  // namespace
}  // namespace kinolab
