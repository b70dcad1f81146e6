#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

namespace kinolab {

/// 64-bit content hash (XXH3) of a byte range: cache keys and file checksums.
std::uint64_t hashBytes(const void* data, std::size_t size, std::uint64_t seed = 0);

inline std::uint64_t hashString(std::string_view text, std::uint64_t seed = 0) {
  return hashBytes(text.data(), text.size(), seed);
}

/// Hash of a whole file's contents; throws FileError when it cannot be read.
std::uint64_t hashFile(const std::string& path);

/// Sixteen lower-case hex digits.
std::string toHex(std::uint64_t value);

}  // namespace kinolab
