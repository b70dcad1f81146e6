#pragma once

#include <cstddef>
#include <vector>

namespace kinolab {

/// Asks the kernel to back the whole 2 MiB pages of [data, data + bytes) with transparent huge
/// pages (madvise(MADV_HUGEPAGE)); a hint, which does nothing where the kernel has them off,
/// and which only memory not yet touched takes at once (the kernel may merge touched pages
/// later). Regions under 4 MiB are left alone.
void adviseHugePages(const void* data, std::size_t bytes);

/// A vector of `count` value-initialised elements whose memory was advised onto huge pages
/// before anything was written: random reads of a large grid (a world's ESDF) then miss the
/// TLB far less (docs/benchmarks.md).
template <typename T>
std::vector<T> vectorOnHugePages(std::size_t count) {
  std::vector<T> vector;
  vector.reserve(count);
  adviseHugePages(vector.data(), vector.capacity() * sizeof(T));
  vector.resize(count);
  return vector;
}

}  // namespace kinolab
