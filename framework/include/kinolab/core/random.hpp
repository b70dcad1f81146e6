#pragma once

#include <cstdint>
#include <string_view>

namespace kinolab {

/// A seeded random stream with a fully specified algorithm (xoshiro256**, seeded through
/// SplitMix64) and its own distributions, so the same seed gives the same numbers bit for bit
/// on every compiler and standard library (std::uniform_real_distribution does not).
class Rng {
 public:
  explicit Rng(std::uint64_t seed);

  /// A stream derived from a parent seed and a name, e.g. ("world", 3): independent streams
  /// for independent parts, so adding one part never shifts the numbers of another.
  static Rng derive(std::uint64_t seed, std::string_view name, std::uint64_t index = 0);

  std::uint64_t nextU64();
  /// Uniform in [0, 1) with 53 random bits.
  double uniform01();
  /// Uniform in [low, high).
  double uniform(double low, double high);
  /// Uniform integer in [low, high], without modulo bias.
  std::int64_t uniformInt(std::int64_t low, std::int64_t high);
  /// Standard normal (Marsaglia polar method).
  double normal();

 private:
  std::uint64_t state_[4];
};

/// One draw per coordinate into a fixed-size vector (an Eigen vector), the last coordinate
/// first: `vector[i] = draw(i)` for i = size - 1 down to 0. That is the order in which g++
/// evaluated such draws when they were the arguments of one constructor call, as they once
/// were in kinolab; C++ leaves that order to the compiler (clang takes them the other way), so
/// the same seed made other worlds and queries there. Spelt out, every world, query and figure
/// made with g++ before is made again, by any compiler.
template <typename Vector, typename Draw>
Vector drawLastFirst(Draw&& draw) {
  Vector vector;
  for (int i = static_cast<int>(vector.size()) - 1; i >= 0; --i) vector[i] = draw(i);
  return vector;
}

}  // namespace kinolab
