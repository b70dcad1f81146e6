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

}  // namespace kinolab
