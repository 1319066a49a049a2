#include "stillmap/mapping/voxel_cloud.h"

#include <algorithm>
#include <cmath>

#include "stillmap/io/error.h"

namespace stillmap {
namespace {

constexpr int kAxisBits = 21;
constexpr std::int64_t kAxisOffset = std::int64_t{1} << (kAxisBits - 1);  // 2^20
constexpr std::uint64_t kAxisMask = (std::uint64_t{1} << kAxisBits) - 1;

// splitmix64 finalizer: spreads neighbouring voxel keys over the table.
inline std::uint64_t Mix(std::uint64_t x) {
  x ^= x >> 30;
  x *= 0xbf58476d1ce4e5b9ULL;
  x ^= x >> 27;
  x *= 0x94d049bb133111ebULL;
  x ^= x >> 31;
  return x;
}

inline std::int64_t AxisIndex(std::uint64_t key, int axis) {
  return static_cast<std::int64_t>((key >> (kAxisBits * (2 - axis))) & kAxisMask) - kAxisOffset;
}

}  // namespace

void VoxelCloudOptions::Validate() const {
  if (!(leaf_size >= 0.001 && leaf_size <= 10.0)) {
    throw InputError("mapping.voxel_leaf must be between 0.001 and 10 m");
  }
}

VoxelCloud::VoxelCloud(const VoxelCloudOptions& options)
    : leaf_size_(options.leaf_size), inverse_leaf_(1.0 / options.leaf_size) {
  options.Validate();
  keys_.assign(1 << 16, kEmpty);
  values_.resize(keys_.size());
}

size_t VoxelCloud::FindSlot(std::uint64_t key) const {
  const size_t mask = keys_.size() - 1;
  size_t slot = Mix(key) & mask;
  while (keys_[slot] != kEmpty && keys_[slot] != key) slot = (slot + 1) & mask;
  return slot;
}

void VoxelCloud::Grow() {
  const std::vector<std::uint64_t> old_keys = std::move(keys_);
  const std::vector<Accumulator> old_values = std::move(values_);
  keys_.assign(old_keys.size() * 2, kEmpty);
  values_.assign(old_keys.size() * 2, Accumulator{});
  for (size_t i = 0; i < old_keys.size(); ++i) {
    if (old_keys[i] == kEmpty) continue;
    const size_t slot = FindSlot(old_keys[i]);
    keys_[slot] = old_keys[i];
    values_[slot] = old_values[i];
  }
}

void VoxelCloud::Insert(const ColoredPoints& points) {
  const float leaf = static_cast<float>(leaf_size_);
  for (size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector3f& p = points.positions[i];
    std::int64_t index[3];
    bool in_range = true;
    for (int axis = 0; axis < 3; ++axis) {
      index[axis] = static_cast<std::int64_t>(std::floor(static_cast<double>(p[axis]) * inverse_leaf_));
      in_range = in_range && index[axis] >= -kAxisOffset && index[axis] < kAxisOffset;
    }
    if (!in_range) {
      ++rejected_;
      continue;
    }
    const std::uint64_t key = (static_cast<std::uint64_t>(index[0] + kAxisOffset) << (2 * kAxisBits)) |
                              (static_cast<std::uint64_t>(index[1] + kAxisOffset) << kAxisBits) |
                              static_cast<std::uint64_t>(index[2] + kAxisOffset);
    if (2 * (size_ + 1) > keys_.size()) Grow();  // load factor <= 0.5
    const size_t slot = FindSlot(key);
    Accumulator& acc = values_[slot];
    if (keys_[slot] == kEmpty) {
      keys_[slot] = key;
      acc = Accumulator{};
      ++size_;
    }
    for (int axis = 0; axis < 3; ++axis) {
      acc.offset_sum[axis] += p[axis] - static_cast<float>(index[axis]) * leaf;
      acc.color_sum[axis] += points.colors[i][axis];
    }
    ++acc.count;
  }
}

std::vector<VoxelPoint> VoxelCloud::Points() const {
  std::vector<size_t> slots;
  slots.reserve(size_);
  for (size_t i = 0; i < keys_.size(); ++i) {
    if (keys_[i] != kEmpty) slots.push_back(i);
  }
  std::sort(slots.begin(), slots.end(), [&](size_t a, size_t b) { return keys_[a] < keys_[b]; });
  std::vector<VoxelPoint> points;
  points.reserve(slots.size());
  for (size_t slot : slots) {
    const Accumulator& acc = values_[slot];
    const float n = static_cast<float>(acc.count);
    VoxelPoint point;
    for (int axis = 0; axis < 3; ++axis) {
      const double corner = static_cast<double>(AxisIndex(keys_[slot], axis)) * leaf_size_;
      point.position[axis] = static_cast<float>(corner + acc.offset_sum[axis] / n);
      point.rgb[axis] = static_cast<std::uint8_t>((acc.color_sum[axis] + acc.count / 2) / acc.count);
    }
    point.count = acc.count;
    points.push_back(point);
  }
  return points;
}

size_t VoxelCloud::MemoryBytes() const {
  return keys_.size() * (sizeof(std::uint64_t) + sizeof(Accumulator));
}

}  // namespace stillmap
