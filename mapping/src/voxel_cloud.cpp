#include "stillmap/mapping/voxel_cloud.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <queue>
#include <stdexcept>

#include "stillmap/io/cpu_usage.h"
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

constexpr std::uint64_t kNoKey = ~std::uint64_t{0};  // a point beyond the key range

// 5 bits of the hash that neither the shard (top bits) nor the index slot (low bits) uses.
inline std::uint32_t TagOf(std::uint64_t mixed) {
  return static_cast<std::uint32_t>(mixed >> 40) & 31;
}

// An index entry: the tag, and the record's number + 1 (0 is an empty slot).
inline std::uint32_t IndexEntry(std::uint64_t mixed, size_t id, int id_bits) {
  return TagOf(mixed) << id_bits | static_cast<std::uint32_t>(id + 1);
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
  for (Shard& shard : shards_) shard.index = MappedArray<std::uint32_t>(1 << 10);
}

VoxelCloud::Record* VoxelCloud::Find(Shard* shard, std::uint64_t key, std::uint64_t mixed,
                                     size_t* free_slot) {
  const size_t mask = shard->index.size() - 1;
  const std::uint32_t tag = TagOf(mixed);
  for (size_t slot = mixed & mask;; slot = (slot + 1) & mask) {
    const std::uint32_t entry = shard->index[slot];
    if (entry == 0) {
      *free_slot = slot;
      return nullptr;
    }
    if (entry >> kIdBits != tag) continue;
    Record& record = shard->At((entry & kIdMask) - 1);
    if (record.Key() == key) return &record;
  }
}

VoxelCloud::Record* VoxelCloud::Add(Shard* shard, std::uint64_t key, std::uint64_t mixed,
                                    size_t free_slot) {
  const size_t id = shard->size();
  if (id + 1 > kIdMask) {
    throw std::length_error(fmt::format("the voxel cloud outgrew {} voxels a shard; raise {}",
                                        kIdMask - 1, OptionKey(&VoxelCloudOptions::leaf_size)));
  }
  shard->records.push_back(
      Record{static_cast<std::uint32_t>(key >> 32), static_cast<std::uint32_t>(key), {}, {}, 0});
  shard->index[free_slot] = IndexEntry(mixed, id, kIdBits);
  return &shard->At(id);
}

void VoxelCloud::Clear() {
  VoxelCloudOptions options;
  options.leaf_size = leaf_size_;
  options.min_points = static_cast<int>(min_points_);
  *this = VoxelCloud(options);
}

void VoxelCloud::Grow(Shard* shard) {
  shard->index = MappedArray<std::uint32_t>(shard->index.size() * 2);
  const size_t mask = shard->index.size() - 1;
  for (size_t id = 0; id < shard->size(); ++id) {  // records in order: no probe reads one
    const std::uint64_t mixed = Mix(shard->At(id).Key());
    size_t slot = mixed & mask;
    while (shard->index[slot] != 0) slot = (slot + 1) & mask;
    shard->index[slot] = IndexEntry(mixed, id, kIdBits);
  }
}

void VoxelCloud::Insert(const ColoredPoints& points) {
  order_.reset();  // new voxels, or counts that now reach min_points
  // Measured on TUM teddy (1 cm, ~2M voxels): a lookup is a cache miss in a large table. Keys are
  // computed for a batch of points and their index entries prefetched, so the misses overlap;
  // neighbouring pixels mostly fall into the same voxel, so the last record is tried first. A
  // second pass prefetching the records the entries name cost more than it saved (benchmark
  // BM_VoxelInsert*: 3.3 against 2.9 ms a frame of known voxels, 10.4 against 8.8 ms of new ones).
  constexpr size_t kBatch = 32;
  const float leaf = static_cast<float>(leaf_size_);
  std::uint64_t keys[kBatch];
  std::uint64_t mixed_keys[kBatch];  // Mix(key), computed once for the prefetch and the lookup
  float offsets[kBatch][3];
  std::uint64_t last_key = kNoKey;
  Record* last = nullptr;
  for (size_t begin = 0; begin < points.size(); begin += kBatch) {
    const size_t count = std::min(kBatch, points.size() - begin);
    for (size_t b = 0; b < count; ++b) {
      keys[b] = KeyOf(points.positions[begin + b], leaf, offsets[b]);
      if (keys[b] == kNoKey) continue;
      const std::uint64_t mixed = mixed_keys[b] = Mix(keys[b]);
      const Shard& shard = shards_[mixed >> (64 - kShardBits)];
      __builtin_prefetch(&shard.index[mixed & (shard.index.size() - 1)]);
    }
    for (size_t b = 0; b < count; ++b) {
      const std::uint64_t key = keys[b];
      if (key == kNoKey) {
        ++rejected_;
        continue;
      }
      if (key != last_key) {
        const std::uint64_t mixed = mixed_keys[b];
        Shard& shard = shards_[mixed >> (64 - kShardBits)];
        if (4 * (shard.size() + 1) > 3 * shard.index.size()) Grow(&shard);  // load factor <= 0.75
        size_t free_slot = 0;
        last = Find(&shard, key, mixed, &free_slot);
        if (last == nullptr) {
          last = Add(&shard, key, mixed, free_slot);
          ++size_;
        }
        last_key = key;
      }
      Record& record = *last;
      if (record.count == 0 && record.color_sum[0] == kRemoved) {  // removed, seen again
        record.color_sum[0] = 0;
        --removed_;
      }
      const std::array<std::uint8_t, 3>& color = points.colors[begin + b];
      for (int axis = 0; axis < 3; ++axis) {
        record.offset_sum[axis] += offsets[b][axis];
        record.color_sum[axis] += color[axis];
      }
      ++record.count;
    }
  }
}

std::uint64_t VoxelCloud::KeyOf(const Eigen::Vector3f& p, float leaf, float offset[3]) const {
  std::int64_t index[3];
  for (int axis = 0; axis < 3; ++axis) {
    index[axis] =
        static_cast<std::int64_t>(std::floor(static_cast<double>(p[axis]) * inverse_leaf_));
    if (index[axis] < -kAxisOffset || index[axis] >= kAxisOffset) return kNoKey;
    offset[axis] = p[axis] - static_cast<float>(index[axis]) * leaf;
  }
  return (static_cast<std::uint64_t>(index[0] + kAxisOffset) << (2 * kAxisBits)) |
         (static_cast<std::uint64_t>(index[1] + kAxisOffset) << kAxisBits) |
         static_cast<std::uint64_t>(index[2] + kAxisOffset);
}

std::vector<std::vector<std::uint32_t>> VoxelCloud::SortedIds() const {
  std::vector<std::vector<std::uint32_t>> ids(kShards);
  for (size_t s = 0; s < kShards; ++s) {
    const Shard& shard = shards_[s];
    for (size_t id = 0; id < shard.size(); ++id) {
      if (shard.At(id).count >= min_points_) ids[s].push_back(static_cast<std::uint32_t>(id));
    }
    std::sort(ids[s].begin(), ids[s].end(), [&shard](std::uint32_t a, std::uint32_t b) {
      return shard.At(a).Key() < shard.At(b).Key();
    });
  }
  return ids;
}

void VoxelCloud::MergeShards(const std::vector<std::vector<std::uint32_t>>& ids,
                             const std::function<void(size_t shard, size_t id)>& visit) const {
  using Head = std::pair<std::uint64_t, size_t>;  // the key a shard offers next, the shard
  std::priority_queue<Head, std::vector<Head>, std::greater<>> heads;
  std::vector<size_t> next(kShards, 0);
  for (size_t s = 0; s < kShards; ++s) {
    if (!ids[s].empty()) heads.emplace(shards_[s].At(ids[s][0]).Key(), s);
  }
  while (!heads.empty()) {
    const size_t s = heads.top().second;
    heads.pop();
    visit(s, ids[s][next[s]]);
    if (++next[s] < ids[s].size()) heads.emplace(shards_[s].At(ids[s][next[s]]).Key(), s);
  }
}

VoxelCloud::KeyOrder VoxelCloud::MakeKeyOrder() const {
  KeyOrder order;
  order.ids = SortedIds();
  size_t count = 0;
  for (const std::vector<std::uint32_t>& ids : order.ids) count += ids.size();
  order.shards.reserve(count);
  MergeShards(order.ids, [&order](size_t shard, size_t) {
    order.shards.push_back(static_cast<std::uint8_t>(shard));
  });
  return order;
}

VoxelCloud::KeyOrder VoxelCloud::LeaveOutRemoved(KeyOrder order) const {
  std::vector<size_t> next(kShards, 0), kept(kShards, 0);
  size_t written = 0;
  for (const std::uint8_t s : order.shards) {  // written never passes the read position
    const std::uint32_t id = order.ids[s][next[s]++];
    if (shards_[s].At(id).count < min_points_) continue;
    order.ids[s][kept[s]++] = id;
    order.shards[written++] = s;
  }
  order.shards.resize(written);
  for (size_t s = 0; s < kShards; ++s) order.ids[s].resize(kept[s]);
  return order;
}

void VoxelCloud::VisitInKeyOrder(const std::function<void(size_t shard, size_t id)>& visit) const {
  if (!order_) {
    MergeShards(SortedIds(), visit);
    return;
  }
  std::vector<size_t> next(kShards, 0);
  for (const std::uint8_t s : order_->shards) {
    const std::uint32_t id = order_->ids[s][next[s]++];
    if (shards_[s].At(id).count >= min_points_) visit(s, id);  // else removed since
  }
}

VoxelPoint VoxelCloud::PointOf(const Record& record) const {
  const float n = static_cast<float>(record.count);
  const std::uint64_t key = record.Key();
  VoxelPoint point;
  for (int axis = 0; axis < 3; ++axis) {
    const double corner = static_cast<double>(AxisIndex(key, axis)) * leaf_size_;
    point.position[axis] = static_cast<float>(corner + record.offset_sum[axis] / n);
    point.rgb[axis] =
        static_cast<std::uint8_t>((record.color_sum[axis] + record.count / 2) / record.count);
  }
  point.count = record.count;
  return point;
}

void VoxelCloud::ForEachPoint(const std::function<void(const VoxelPoint&)>& visit) const {
  VisitInKeyOrder([&](size_t shard, size_t id) { visit(PointOf(shards_[shard].At(id))); });
}

size_t VoxelCloud::RemoveIf(const std::function<bool(const VoxelPoint&)>& drop) {
  if (!order_) order_ = MakeKeyOrder();
  size_t removed = 0;
  VisitInKeyOrder([&](size_t shard, size_t id) {
    Record& record = shards_[shard].At(id);
    if (!drop(PointOf(record))) return;
    record = Record{record.key_high, record.key_low, {}, {kRemoved, 0, 0}, 0};
    ++removed;
  });
  removed_ += removed;
  return removed;
}

std::vector<VoxelPoint> VoxelCloud::Points() const {
  std::vector<VoxelPoint> points;
  points.reserve(size());
  ForEachPoint([&points](const VoxelPoint& point) { points.push_back(point); });
  return points;
}

std::vector<VoxelPoint> VoxelCloud::TakePoints() {
  for (Shard& shard : shards_) shard.index = {};  // visiting in key order reads the records only
  KeyOrder kept = order_ ? LeaveOutRemoved(std::move(*order_)) : MakeKeyOrder();
  order_.reset();
  std::vector<std::vector<std::uint32_t>> ids = std::move(kept.ids);
  std::vector<std::uint8_t> order = std::move(kept.shards);  // the shard of each point
  // Each shard's points in key order, its records handed back as soon as they are made: the
  // points (20 bytes) replace the records (36) instead of coming on top of them.
  std::vector<std::vector<MappedArray<VoxelPoint>>> parts(kShards);
  for (size_t s = 0; s < kShards; ++s) {
    for (size_t i = 0; i < ids[s].size(); ++i) {
      if (i % kPartPoints == 0) parts[s].emplace_back(std::min(kPartPoints, ids[s].size() - i));
      parts[s].back()[i % kPartPoints] = PointOf(shards_[s].At(ids[s][i]));
    }
    std::vector<std::uint32_t>().swap(ids[s]);
    shards_[s].records.clear();
  }
  ReleaseFreedMemory();  // the sorted numbers (the records' and index's pages went already)
  // The parts merged in key order, each part handed back once it is read.
  std::vector<VoxelPoint> points;
  points.reserve(order.size());
  std::vector<size_t> next(kShards, 0);
  for (const std::uint8_t s : order) {
    const size_t i = next[s]++;
    points.push_back(parts[s][i / kPartPoints][i % kPartPoints]);
    if ((i + 1) % kPartPoints == 0) parts[s][i / kPartPoints] = {};
  }
  Clear();
  return points;
}

size_t VoxelCloud::OutputSize() const {
  if (min_points_ <= 1) return size();  // every voxel kept is written: no scan of the records
  size_t count = 0;
  for (const Shard& shard : shards_) {
    for (size_t id = 0; id < shard.size(); ++id) count += shard.At(id).count >= min_points_;
  }
  return count;
}

size_t VoxelCloud::TableBytes() const {
  size_t bytes = 0;
  for (const Shard& shard : shards_) {
    bytes += shard.index.size() * sizeof(std::uint32_t) + shard.records.MemoryBytes();
  }
  return bytes;
}

size_t VoxelCloud::MemoryBytes() const {
  size_t bytes = TableBytes();
  if (order_) {
    bytes += order_->shards.capacity();
    for (const std::vector<std::uint32_t>& ids : order_->ids) bytes += ids.capacity() * 4;
  }
  return bytes;
}

}  // namespace stillmap
