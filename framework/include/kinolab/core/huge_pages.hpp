#pragma once

#include <cstddef>
#include <vector>

namespace kinolab {

/// Asks the kernel to back the whole 2 MiB pages of [data, data + bytes) with transparent huge
/// pages (madvise(MADV_HUGEPAGE)); a hint, which does nothing where the kernel has them off,
/// and which only memory not yet touched takes at once (the kernel may merge touched pages
/// later). Regions under 4 MiB are left alone.
void adviseHugePages(const void* data, std::size_t bytes);

/// Reserves room for `count` elements in the empty `vector` and advises huge pages for it
/// before anything is written: random reads of a large grid (a world's ESDF) then miss the TLB
/// far less (docs/benchmarks.md).
template <typename T>
void reserveOnHugePages(std::vector<T>& vector, std::size_t count) {
  vector.reserve(count);
  adviseHugePages(vector.data(), vector.capacity() * sizeof(T));
}

}  // namespace kinolab
