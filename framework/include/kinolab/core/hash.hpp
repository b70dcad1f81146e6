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

/// hashBytes() of bytes given piece by piece: the digest of the pieces' concatenation.
class StreamHash {
 public:
  StreamHash();
  ~StreamHash();
  StreamHash(const StreamHash&) = delete;
  StreamHash& operator=(const StreamHash&) = delete;
  void update(const void* data, std::size_t size);
  std::uint64_t digest() const;

 private:
  void* state_;  // an XXH3_state_t
};

/// Hash of a whole file's contents; throws FileError when it cannot be read.
std::uint64_t hashFile(const std::string& path);

/// Sixteen lower-case hex digits.
std::string toHex(std::uint64_t value);

}  // namespace kinolab
