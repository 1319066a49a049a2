#include "stillmap/mapping/voxel_cloud.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "stillmap/io/error.h"
#include "stillmap/io/option_names.h"

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
    throw InputError(fmt::format("{} must be between 0.001 and 10 m", OptionKey(*this, leaf_size)));
  }
  if (min_points < 1)
    throw InputError(fmt::format("{} must be >= 1", OptionKey(*this, min_points)));
}

VoxelCloud::VoxelCloud(const VoxelCloudOptions& options)
    : leaf_size_(options.leaf_size),
      inverse_leaf_(1.0 / options.leaf_size),
      min_points_(static_cast<std::uint32_t>(std::max(1, options.min_points))),
      shards_(kShards) {
  options.Validate();
  for (Shard& shard : shards_) shard.slots.assign(1 << 10, Slot{kEmpty, {}, {}, 0});
}

size_t VoxelCloud::FindSlot(const Shard& shard, std::uint64_t key, std::uint64_t mixed) {
  const size_t mask = shard.slots.size() - 1;
  size_t slot = mixed & mask;
  while (shard.slots[slot].key != kEmpty && shard.slots[slot].key != key) {
    slot = (slot + 1) & mask;
  }
  return slot;
}

void VoxelCloud::Clear() {
  for (Shard& shard : shards_) {
    std::fill(shard.slots.begin(), shard.slots.end(), Slot{kEmpty, {}, {}, 0});
    shard.size = 0;
  }
  size_ = 0;
  removed_ = 0;
  rejected_ = 0;
}

void VoxelCloud::Grow(Shard* shard) {
  const std::vector<Slot> old = std::move(shard->slots);
  shard->slots.assign(old.size() * 2, Slot{kEmpty, {}, {}, 0});
  for (const Slot& slot : old) {
    if (slot.key != kEmpty) shard->slots[FindSlot(*shard, slot.key, Mix(slot.key))] = slot;
  }
}

void VoxelCloud::Insert(const ColoredPoints& points) {
  // Measured on TUM teddy (1 cm, ~2M voxels): a lookup is a cache miss in a table of ~160 MB. Keys
  // are computed for a batch of points and their slots prefetched, so the misses overlap; and
  // neighbouring pixels mostly fall into the same voxel, so the last slot is tried first.
  constexpr size_t kBatch = 32;
  const float leaf = static_cast<float>(leaf_size_);
  std::uint64_t keys[kBatch];
  std::uint64_t mixed_keys[kBatch];  // Mix(key), computed once for the prefetch and the lookup
  float offsets[kBatch][3];
  std::uint64_t last_key = kEmpty;
  Slot* last_slot = nullptr;
  for (size_t begin = 0; begin < points.size(); begin += kBatch) {
    const size_t count = std::min(kBatch, points.size() - begin);
    for (size_t b = 0; b < count; ++b) {
      const Eigen::Vector3f& p = points.positions[begin + b];
      std::int64_t index[3];
      bool in_range = true;
      for (int axis = 0; axis < 3; ++axis) {
        index[axis] =
            static_cast<std::int64_t>(std::floor(static_cast<double>(p[axis]) * inverse_leaf_));
        in_range = in_range && index[axis] >= -kAxisOffset && index[axis] < kAxisOffset;
        offsets[b][axis] = p[axis] - static_cast<float>(index[axis]) * leaf;
      }
      if (!in_range) {
        keys[b] = kEmpty;
        continue;
      }
      keys[b] = (static_cast<std::uint64_t>(index[0] + kAxisOffset) << (2 * kAxisBits)) |
                (static_cast<std::uint64_t>(index[1] + kAxisOffset) << kAxisBits) |
                static_cast<std::uint64_t>(index[2] + kAxisOffset);
      const std::uint64_t mixed = mixed_keys[b] = Mix(keys[b]);
      const Shard& shard = shards_[mixed >> (64 - kShardBits)];
      __builtin_prefetch(&shard.slots[mixed & (shard.slots.size() - 1)], 1);
    }
    for (size_t b = 0; b < count; ++b) {
      const std::uint64_t key = keys[b];
      if (key == kEmpty) {
        ++rejected_;
        continue;
      }
      if (key != last_key) {
        const std::uint64_t mixed = mixed_keys[b];
        Shard& shard = shards_[mixed >> (64 - kShardBits)];
        if (4 * (shard.size + 1) > 3 * shard.slots.size()) Grow(&shard);  // load factor <= 0.75
        last_slot = &shard.slots[FindSlot(shard, key, mixed)];
        if (last_slot->key == kEmpty) {
          *last_slot = Slot{key, {}, {}, 0};
          ++shard.size;
          ++size_;
        }
        last_key = key;
      }
      Slot& slot = *last_slot;
      if (slot.count == 0 && slot.color_sum[0] == kRemoved) {  // removed, seen again
        slot.color_sum[0] = 0;
        --removed_;
      }
      const std::array<std::uint8_t, 3>& color = points.colors[begin + b];
      for (int axis = 0; axis < 3; ++axis) {
        slot.offset_sum[axis] += offsets[b][axis];
        slot.color_sum[axis] += color[axis];
      }
      ++slot.count;
    }
  }
}

std::vector<std::pair<std::uint64_t, size_t>> VoxelCloud::SortedOutputSlots() const {
  // Sorting (key, slot) pairs keeps the comparisons in cache; sorting pointers into the table made
  // every comparison a cache miss (Bonn, 6 M voxels: 3.5 s to write the outputs).
  std::vector<std::pair<std::uint64_t, size_t>> used;
  used.reserve(size());
  for (size_t s = 0; s < kShards; ++s) {
    const std::vector<Slot>& slots = shards_[s].slots;
    for (size_t i = 0; i < slots.size(); ++i) {
      if (slots[i].key != kEmpty && slots[i].count >= min_points_) {
        used.emplace_back(slots[i].key, s << 40 | i);
      }
    }
  }
  std::sort(used.begin(), used.end());
  return used;
}

VoxelPoint VoxelCloud::PointOf(const Slot& slot) const {
  const float n = static_cast<float>(slot.count);
  VoxelPoint point;
  for (int axis = 0; axis < 3; ++axis) {
    const double corner = static_cast<double>(AxisIndex(slot.key, axis)) * leaf_size_;
    point.position[axis] = static_cast<float>(corner + slot.offset_sum[axis] / n);
    point.rgb[axis] =
        static_cast<std::uint8_t>((slot.color_sum[axis] + slot.count / 2) / slot.count);
  }
  point.count = slot.count;
  return point;
}

void VoxelCloud::ForEachPoint(const std::function<void(const VoxelPoint&)>& visit) const {
  for (const auto& [key, position] : SortedOutputSlots()) visit(PointOf(SlotAt(position)));
}

size_t VoxelCloud::RemoveIf(const std::function<bool(const VoxelPoint&)>& drop) {
  size_t removed = 0;
  for (const auto& [key, position] : SortedOutputSlots()) {
    Slot& slot = SlotAt(position);
    if (!drop(PointOf(slot))) continue;
    slot = Slot{slot.key, {}, {kRemoved, 0, 0}, 0};
    ++removed;
  }
  removed_ += removed;
  return removed;
}

std::vector<VoxelPoint> VoxelCloud::Points() const {
  std::vector<VoxelPoint> points;
  points.reserve(size());
  ForEachPoint([&points](const VoxelPoint& point) { points.push_back(point); });
  return points;
}

size_t VoxelCloud::OutputSize() const {
  if (min_points_ <= 1) return size();  // every voxel kept is written: no scan of the table
  size_t count = 0;
  for (const Shard& shard : shards_) {
    for (const Slot& slot : shard.slots) count += slot.key != kEmpty && slot.count >= min_points_;
  }
  return count;
}

size_t VoxelCloud::MemoryBytes() const {
  size_t bytes = 0;
  for (const Shard& shard : shards_) bytes += shard.slots.size() * sizeof(Slot);
  return bytes;
}

}  // namespace stillmap
