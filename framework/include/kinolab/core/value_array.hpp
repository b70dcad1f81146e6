#pragma once

#include <cstddef>
#include <memory>
#include <span>
#include <utility>
#include <vector>

namespace kinolab {

/// An array of T that owns its values (a std::vector) or views read-only memory that another
/// object keeps alive and unchanged (a memory-mapped file: a world from the cache is read where
/// it lies, not copied). Reads go through one pointer either way. Writing to a view first copies
/// it (mutableData()), so a viewed array behaves as an owned one; the size never changes but
/// by assignment, so the pointer stays valid.
template <typename T>
class ValueArray {
 public:
  ValueArray() = default;
  /// Owns `values` (implicit: a vector is an array of its own, so that a function taking a
  /// ValueArray takes a vector as well).
  ValueArray(std::vector<T>&& values)
      : owned_(std::move(values)), data_(owned_.data()), size_(owned_.size()) {}
  /// Views the `count` values at `data`, which `keeper` keeps alive and unchanged.
  ValueArray(std::shared_ptr<const void> keeper, const T* data, std::size_t count)
      : keeper_(std::move(keeper)), data_(data), size_(count) {}

  ValueArray(const ValueArray& other)
      : owned_(other.owned_),
        keeper_(other.keeper_),
        data_(keeper_ ? other.data_ : owned_.data()),
        size_(other.size_) {}
  ValueArray(ValueArray&& other) noexcept
      : owned_(std::move(other.owned_)),
        keeper_(std::move(other.keeper_)),
        data_(std::exchange(other.data_, nullptr)),
        size_(std::exchange(other.size_, 0)) {}
  /// An owned array copied into an owned one reuses its memory (a flight's window each frame).
  ValueArray& operator=(const ValueArray& other) {
    if (this == &other) return *this;
    if (other.keeper_) {
      owned_ = std::vector<T>();
      keeper_ = other.keeper_;
      data_ = other.data_;
    } else {
      owned_ = other.owned_;
      keeper_.reset();
      data_ = owned_.data();
    }
    size_ = other.size_;
    return *this;
  }
  ValueArray& operator=(ValueArray&& other) noexcept {
    if (this == &other) return *this;
    owned_ = std::move(other.owned_);
    keeper_ = std::move(other.keeper_);
    data_ = std::exchange(other.data_, nullptr);
    size_ = std::exchange(other.size_, 0);
    return *this;
  }
  ~ValueArray() = default;

  const T* data() const { return data_; }
  std::size_t size() const { return size_; }
  bool empty() const { return size_ == 0; }
  const T& operator[](std::size_t index) const { return data_[index]; }
  const T* begin() const { return data_; }
  const T* end() const { return data_ + size_; }
  std::span<const T> span() const { return {data_, size_}; }

  /// Whether the values are another object's (viewed, not owned).
  bool viewed() const { return keeper_ != nullptr; }
  /// Bytes the values take in memory (an owned array's capacity, a view's values).
  std::size_t bytes() const { return (keeper_ ? size_ : owned_.capacity()) * sizeof(T); }

  /// The values for writing (a view is copied first).
  T* mutableData() {
    if (keeper_) own();
    return owned_.data();
  }
  std::span<T> mutableSpan() { return {mutableData(), size_}; }

  /// The values as a vector of their own (a view's copied), leaving this array empty.
  std::vector<T> release() && {
    if (keeper_) own();
    std::vector<T> values = std::move(owned_);
    owned_ = std::vector<T>();
    data_ = nullptr;
    size_ = 0;
    return values;
  }

 private:
  void own() {
    owned_.assign(data_, data_ + size_);
    keeper_.reset();
    data_ = owned_.data();
  }

  std::vector<T> owned_;
  std::shared_ptr<const void> keeper_;
  const T* data_ = nullptr;
  std::size_t size_ = 0;
};

}  // namespace kinolab
