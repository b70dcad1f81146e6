#include "kinolab/core/random.hpp"

#include <cmath>

#include "kinolab/core/error.hpp"
#include "kinolab/core/hash.hpp"

namespace kinolab {
namespace {

std::uint64_t splitMix64(std::uint64_t& x) {
  std::uint64_t z = (x += 0x9e3779b97f4a7c15ULL);
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  return z ^ (z >> 31);
}

std::uint64_t rotateLeft(std::uint64_t x, int k) { return (x << k) | (x >> (64 - k)); }

}  // namespace

Rng::Rng(std::uint64_t seed) {
  for (auto& word : state_) word = splitMix64(seed);
}

Rng Rng::derive(std::uint64_t seed, std::string_view name, std::uint64_t index) {
  const std::uint64_t mixed[3] = {seed, hashString(name), index};
  return Rng(hashBytes(mixed, sizeof(mixed)));
}

std::uint64_t Rng::nextU64() {
  const std::uint64_t result = rotateLeft(state_[1] * 5, 7) * 9;
  const std::uint64_t t = state_[1] << 17;
  state_[2] ^= state_[0];
  state_[3] ^= state_[1];
  state_[1] ^= state_[2];
  state_[0] ^= state_[3];
  state_[2] ^= t;
  state_[3] = rotateLeft(state_[3], 45);
  return result;
}

double Rng::uniform01() { return static_cast<double>(nextU64() >> 11) * 0x1.0p-53; }

double Rng::uniform(double low, double high) { return low + (high - low) * uniform01(); }

std::int64_t Rng::uniformInt(std::int64_t low, std::int64_t high) {
  if (high < low) throw InvalidArgument("Rng::uniformInt: empty range");
  const std::uint64_t span = static_cast<std::uint64_t>(high - low) + 1;
  if (span == 0) return static_cast<std::int64_t>(nextU64());  // the full 64-bit range
  const std::uint64_t limit = ~std::uint64_t{0} - (~std::uint64_t{0} % span);
  std::uint64_t draw = nextU64();
  while (draw >= limit) draw = nextU64();
  return low + static_cast<std::int64_t>(draw % span);
}

double Rng::normal() {
  double u = 0.0;
  double v = 0.0;
  double s = 0.0;
  do {
    u = uniform(-1.0, 1.0);
    v = uniform(-1.0, 1.0);
    s = u * u + v * v;
  } while (s >= 1.0 || s == 0.0);
  return u * std::sqrt(-2.0 * std::log(s) / s);
}

}  // namespace kinolab
