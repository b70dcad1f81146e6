#pragma once

#include <sys/mman.h>

#include <cstddef>
#include <cstdlib>
#include <new>
#include <vector>

namespace kinolab {

/// An allocator for large arrays read at random (the ESDF): blocks of 2 MiB and more are
/// aligned to 2 MiB and marked MADV_HUGEPAGE, so that where the kernel's transparent huge
/// pages are enabled (`madvise` or `always`) a query costs a cache miss, not also a
/// page-table walk. Elsewhere it changes nothing.
template <typename T>
struct HugePageAllocator {
  using value_type = T;
  static constexpr std::size_t kHugePage = std::size_t{1} << 21;

  HugePageAllocator() = default;
  template <typename U>
  HugePageAllocator(const HugePageAllocator<U>&) noexcept {}

  T* allocate(std::size_t count) {
    const std::size_t bytes = count * sizeof(T);
    if (bytes < kHugePage) return static_cast<T*>(::operator new(bytes));
    const std::size_t rounded = (bytes + kHugePage - 1) / kHugePage * kHugePage;
    void* memory = std::aligned_alloc(kHugePage, rounded);
    if (!memory) throw std::bad_alloc();
    madvise(memory, rounded, MADV_HUGEPAGE);  // advice only: failure changes nothing
    return static_cast<T*>(memory);
  }
  void deallocate(T* pointer, std::size_t count) noexcept {
    if (count * sizeof(T) < kHugePage) {
      ::operator delete(pointer);
    } else {
      std::free(pointer);
    }
  }
  template <typename U>
  bool operator==(const HugePageAllocator<U>&) const noexcept {
    return true;
  }
};

}  // namespace kinolab
