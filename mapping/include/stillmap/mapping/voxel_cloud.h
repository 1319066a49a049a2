// A voxelized colored point cloud: one point per occupied voxel, the centroid of the points that
// fell into it, with their mean color.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <functional>
#include <utility>
#include <vector>

#include "stillmap/io/cloud_files.h"
#include "stillmap/mapping/back_projection.h"

namespace stillmap {

struct VoxelCloudOptions {
  double leaf_size = 0.01;  // voxel edge [m]
  // Voxels that received fewer points are left out of the output: isolated depth noise and
  // transient objects hit few points, surfaces seen over many frames many.
  int min_points = 1;

  // Throws InputError naming the first impossible value.
  void Validate() const;

  // Every field under its configuration key (io/option_fields.h).
  template <typename Self, typename Visitor>
  static void VisitFields(Self& self, Visitor& visit) {
    visit("leaf_size", self.leaf_size, "voxel edge of the colored cloud [m]");
    visit("min_points", self.min_points,
          "voxels with fewer points are left out of map.ply/map.pcd");
  }
};

// Hash-keyed voxel grid with open addressing (linear probing, power-of-two capacity, load factor
// at most 0.75: 40 bytes a slot, about 53 bytes a voxel), in kShards tables chosen by the hash's
// top bits, each growing on its own: a table that doubles holds its old copy beside the new one,
// and one of 64 doubling costs 1/64 of what the whole cloud's would (640 MiB on the floor). Written
// here rather than taken from PCL: PCL's VoxelGrid works on a finished cloud, needs a second pass
// and returns its input unfiltered when the grid's index range overflows (large extents at 1 cm);
// this grid accumulates frame by frame in O(1) per point and its key range is ±10 km at 1 cm.
class VoxelCloud {
 public:
  explicit VoxelCloud(const VoxelCloudOptions& options = {});

  // Accumulates points (world frame) into their voxels. Points beyond the key range (2^20 voxels
  // from the origin along any axis) are counted in rejected_count() and left out.
  void Insert(const ColoredPoints& points);

  // Calls `visit` with the centroid and mean color of every voxel, in a deterministic order
  // (sorted by voxel key), without materializing the cloud.
  void ForEachPoint(const std::function<void(const VoxelPoint&)>& visit) const;

  // Removes every output voxel for which `drop` returns true; `drop` sees them in ForEachPoint's
  // order. A removed voxel that receives points again starts afresh. Returns how many it removed.
  size_t RemoveIf(const std::function<bool(const VoxelPoint&)>& drop);

  // Empties the cloud and keeps the table's capacity: a map fused again (loop corrections) does
  // not grow a new table through every doubling, with the old and the new one held at each.
  void Clear();

  // The same points as a vector (tests and small clouds).
  std::vector<VoxelPoint> Points() const;

  size_t size() const { return size_ - removed_; }
  size_t rejected_count() const { return rejected_; }
  double leaf_size() const { return leaf_size_; }
  // The key range: coordinates within +-Extent(leaf) of the origin on every axis [m].
  static double Extent(double leaf_size) { return 1048575.0 * leaf_size; }
  // Voxels that reach min_points (what ForEachPoint and Points visit).
  size_t OutputSize() const;
  // Bytes held by the table.
  size_t MemoryBytes() const;

 private:
  // Key and sums side by side: one cache line touched per lookup.
  struct Slot {
    std::uint64_t key;
    float offset_sum[3];  // sum of positions relative to the voxel's min corner [m]
    std::uint32_t color_sum[3];
    std::uint32_t count;
  };
  struct Shard {
    std::vector<Slot> slots;
    size_t size = 0;  // keys stored, removed ones included
  };
  static constexpr int kShardBits = 6;
  static constexpr size_t kShards = size_t{1} << kShardBits;
  static constexpr std::uint64_t kEmpty = ~std::uint64_t{0};
  static constexpr std::uint32_t kRemoved = ~std::uint32_t{0};  // color_sum[0] of a removed voxel

  static void Grow(Shard* shard);
  // The slot of `key` in its shard (whose hash is `mixed`): its own or the empty one it would take.
  static size_t FindSlot(const Shard& shard, std::uint64_t key, std::uint64_t mixed);
  // The output voxels as (key, shard << 40 | slot index), sorted by key. The pairs are handed
  // out as they are: a second list of the positions alone would hold 8 more bytes a voxel.
  std::vector<std::pair<std::uint64_t, size_t>> SortedOutputSlots() const;
  Slot& SlotAt(size_t position) { return shards_[position >> 40].slots[position & kSlotMask]; }
  const Slot& SlotAt(size_t position) const {
    return shards_[position >> 40].slots[position & kSlotMask];
  }
  static constexpr size_t kSlotMask = (size_t{1} << 40) - 1;
  VoxelPoint PointOf(const Slot& slot) const;

  double leaf_size_;
  double inverse_leaf_;
  std::uint32_t min_points_;
  std::vector<Shard> shards_;
  size_t size_ = 0;     // keys stored, removed ones included
  size_t removed_ = 0;  // stored keys emptied by RemoveIf (count 0)
  size_t rejected_ = 0;
};

}  // namespace stillmap
