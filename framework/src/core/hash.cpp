#include "kinolab/core/hash.hpp"

#include <xxhash.h>

#include <array>
#include <fstream>

#include "kinolab/core/error.hpp"

namespace kinolab {

std::uint64_t hashBytes(const void* data, std::size_t size, std::uint64_t seed) {
  return XXH3_64bits_withSeed(data, size, seed);
}

std::uint64_t hashFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw FileError(path + ": cannot open file");
  XXH3_state_t* state = XXH3_createState();
  XXH3_64bits_reset(state);
  std::array<char, 1 << 16> buffer{};
  while (in) {
    in.read(buffer.data(), buffer.size());
    XXH3_64bits_update(state, buffer.data(), static_cast<std::size_t>(in.gcount()));
  }
  const bool failed = in.bad();
  const std::uint64_t digest = XXH3_64bits_digest(state);
  XXH3_freeState(state);
  if (failed) throw FileError(path + ": read error");
  return digest;
}

std::string toHex(std::uint64_t value) {
  static constexpr char kDigits[] = "0123456789abcdef";
  std::string text(16, '0');
  for (int i = 15; i >= 0; --i, value >>= 4)
    text[static_cast<std::size_t>(i)] = kDigits[value & 15];
  return text;
}

}  // namespace kinolab
