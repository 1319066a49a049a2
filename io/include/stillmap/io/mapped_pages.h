// Bulk memory taken straight from the system (an anonymous mapping) and handed back to it the
// moment it is freed. For the large blocks a build makes through the frame loop and frees at the
// end (the voxel records, the keyframe views): from the allocator they end up interleaved with
// everything else made meanwhile, and once freed they stay resident as holes that the finishing's
// points cannot use (floor seed 1: freeing about 220 MiB of views and index gave back 22).
#pragma once

#include <cstddef>
#include <new>
#include <type_traits>
#include <utility>
#include <vector>

namespace stillmap {

// `bytes` of zeroed memory from the system; throws std::bad_alloc when it has none.
void* MapPages(std::size_t bytes);
// Hands back what MapPages(bytes) returned (nullptr: nothing).
void UnmapPages(void* pages, std::size_t bytes);

// `count` values in pages of their own, value-initialised (plain values: the zeroed pages as they
// come); move-only.
template <typename T>
class MappedArray {
  static_assert(std::is_trivially_destructible_v<T>, "MappedArray never runs destructors");

 public:
  MappedArray() = default;
  explicit MappedArray(std::size_t count)
      : data_(static_cast<T*>(MapPages(count * sizeof(T)))), size_(count) {
    if constexpr (!std::is_trivially_default_constructible_v<T>) {
      for (std::size_t i = 0; i < count; ++i) new (data_ + i) T();
    }
  }
  ~MappedArray() { UnmapPages(data_, size_ * sizeof(T)); }
  MappedArray(MappedArray&& other) noexcept
      : data_(std::exchange(other.data_, nullptr)), size_(std::exchange(other.size_, 0)) {}
  MappedArray& operator=(MappedArray&& other) noexcept {  // hands its own pages back first
    if (this == &other) return *this;
    UnmapPages(data_, size_ * sizeof(T));
    data_ = std::exchange(other.data_, nullptr);
    size_ = std::exchange(other.size_, 0);
    return *this;
  }
  MappedArray(const MappedArray&) = delete;
  MappedArray& operator=(const MappedArray&) = delete;

  T* data() { return data_; }
  const T* data() const { return data_; }
  std::size_t size() const { return size_; }
  T& operator[](std::size_t i) { return data_[i]; }
  const T& operator[](std::size_t i) const { return data_[i]; }

 private:
  T* data_ = nullptr;
  std::size_t size_ = 0;
};

// A growing array of plain values in MappedArray pages of 2^kPageBits values: it is never copied
// as it grows, leaves no block behind, and its pages go back to the system when it is freed (for
// indexes that grow with the recording and are freed before the map is fused again).
template <typename T, int kPageBits>
class PagedArray {
 public:
  static constexpr std::size_t kPageValues = std::size_t{1} << kPageBits;

  void push_back(const T& value) {
    if (size_ == pages_.size() * kPageValues) pages_.emplace_back(kPageValues);
    (*this)[size_++] = value;
  }
  T& operator[](std::size_t i) { return pages_[i >> kPageBits][i & (kPageValues - 1)]; }
  const T& operator[](std::size_t i) const { return pages_[i >> kPageBits][i & (kPageValues - 1)]; }
  std::size_t size() const { return size_; }
  // The pages' bytes and their list's.
  std::size_t MemoryBytes() const {
    return pages_.size() * kPageValues * sizeof(T) + pages_.capacity() * sizeof(MappedArray<T>);
  }
  // Hands every page back.
  void clear() {
    std::vector<MappedArray<T>>().swap(pages_);
    size_ = 0;
  }

 private:
  std::vector<MappedArray<T>> pages_;
  std::size_t size_ = 0;
};

}  // namespace stillmap
