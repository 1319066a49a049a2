// A voxelized colored point cloud: one point per occupied voxel, the centroid of the points that
// fell into it, with their mean color.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <utility>
#include <vector>

#include "stillmap/io/cloud_files.h"
#include "stillmap/io/mapped_pages.h"
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

// Hash-keyed voxel grid in kShards shards chosen by the hash's top bits. A shard keeps its voxels'
// records (36 bytes) in pages that never move, in the order the voxels were first seen, and an
// open-addressing index of 4-byte entries (linear probing, power-of-two capacity, load factor at
// most 0.75): about 43 bytes a voxel, where one table of 40-byte slots took 53 to 107 (1280 MiB
// for the 12 M voxels of the synthetic floor; 603 MiB now). An entry holds the record's number
// and 5 bits of the key's hash, so a probe reads a record only when those agree. An index that
// doubles is rebuilt from the records, read in order. Pages and index are taken straight from the
// system (io/mapped_pages.h), so the index's doublings and the freed records leave no holes in
// the heap. Written here rather than taken from PCL:
// PCL's VoxelGrid works on a finished cloud, needs a second pass and returns its input unfiltered
// when the grid's index range overflows (large extents at 1 cm); this grid accumulates frame by
// frame in O(1) per point and its key range is ±10 km at 1 cm.
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

  // Empties the cloud and hands its table back (pages of their own: mapped_pages.h). A map emptied
  // to be fused again after loop corrections holds nothing until then; growing the table again
  // costs no peak, as each of the 64 shards doubles its index on its own and records come in
  // pages.
  void Clear();

  // The same points as a vector (tests and small clouds).
  std::vector<VoxelPoint> Points() const;
  // The points as Points() gives them, the cloud left empty: its lookup index is freed first, and
  // each shard's records as soon as its points are made (in parts, merged into key order at the
  // end), so the points replace the records rather than come on top of them.
  std::vector<VoxelPoint> TakePoints();

  size_t size() const { return size_ - removed_; }
  size_t rejected_count() const { return rejected_; }
  double leaf_size() const { return leaf_size_; }
  // The key range: coordinates within +-Extent(leaf) of the origin on every axis [m].
  static double Extent(double leaf_size) { return 1048575.0 * leaf_size; }
  // Voxels that reach min_points (what ForEachPoint and Points visit).
  size_t OutputSize() const;
  // Bytes held by the table: its records and their index.
  size_t TableBytes() const;
  // Bytes held in all: the table and the key order a removal keeps (5 bytes a voxel).
  size_t MemoryBytes() const;

 private:
  // One voxel's sums; the key split in two words keeps the record at 36 bytes.
  struct Record {
    std::uint32_t key_high;
    std::uint32_t key_low;
    float offset_sum[3];  // sum of positions relative to the voxel's min corner [m]
    std::uint32_t color_sum[3];
    std::uint32_t count;
    std::uint64_t Key() const { return std::uint64_t{key_high} << 32 | key_low; }
  };
  static constexpr int kShardBits = 6;
  static constexpr size_t kShards = size_t{1} << kShardBits;
  static constexpr int kPageBits = 11;  // records a page: 2048 (72 KiB)
  struct Shard {
    MappedArray<std::uint32_t> index;       // 0: empty; else tag << kIdBits | (record number + 1)
    PagedArray<Record, kPageBits> records;  // removed ones included
    size_t size() const { return records.size(); }
    Record& At(size_t id) { return records[id]; }
    const Record& At(size_t id) const { return records[id]; }
  };
  static constexpr size_t kPartPoints = size_t{1} << 14;  // TakePoints's parts (320 KiB)
  static constexpr int kIdBits = 27;  // records per shard < 2^27: 8.6 G voxels in all
  static constexpr std::uint32_t kIdMask = (std::uint32_t{1} << kIdBits) - 1;
  static constexpr std::uint32_t kRemoved = ~std::uint32_t{0};  // color_sum[0] of a removed voxel

  // The record of `key` (whose hash is `mixed`) in `shard`, or nullptr and in `*free_slot` the
  // index slot it would take.
  static Record* Find(Shard* shard, std::uint64_t key, std::uint64_t mixed, size_t* free_slot);
  // A new record for `key` in the index slot Find returned.
  static Record* Add(Shard* shard, std::uint64_t key, std::uint64_t mixed, size_t free_slot);
  static void Grow(Shard* shard);
  // The voxel key of `p` and its offset from the voxel's min corner, or ~0 beyond the key range.
  std::uint64_t KeyOf(const Eigen::Vector3f& p, float leaf, float offset[3]) const;
  // Each shard's output records (count >= min_points), their numbers sorted by key (4 bytes a
  // voxel). A list of (key, position) pairs sorted at once held 16 (180 MiB on the floor).
  std::vector<std::vector<std::uint32_t>> SortedIds() const;
  // Calls `visit` with the shard and record number of each of `ids` (SortedIds), merged across
  // the shards into key order.
  void MergeShards(const std::vector<std::vector<std::uint32_t>>& ids,
                   const std::function<void(size_t shard, size_t id)>& visit) const;
  // The output voxels in key order: each shard's record numbers sorted by key (SortedIds) and the
  // shard of each voxel in key order, 5 bytes a voxel.
  struct KeyOrder {
    std::vector<std::vector<std::uint32_t>> ids;
    std::vector<std::uint8_t> shards;
  };
  KeyOrder MakeKeyOrder() const;
  // `order` without the voxels removed since it was made.
  KeyOrder LeaveOutRemoved(KeyOrder order) const;
  // Calls `visit` with the shard and record number of every output voxel, in key order: by the
  // kept order when there is one (voxels removed since are skipped), else merged afresh.
  void VisitInKeyOrder(const std::function<void(size_t shard, size_t id)>& visit) const;
  VoxelPoint PointOf(const Record& record) const;

  double leaf_size_;
  double inverse_leaf_;
  std::uint32_t min_points_;
  std::vector<Shard> shards_;
  size_t size_ = 0;     // keys stored, removed ones included
  size_t removed_ = 0;  // stored keys emptied by RemoveIf (count 0)
  size_t rejected_ = 0;
  // The key order made by the first RemoveIf since the last Insert, kept for the visits after it
  // while nothing is inserted: the map cleaning visits the cloud four times, and sorting and
  // merging 12 M voxels took 2.7 s each time (BM_VoxelVisit).
  std::optional<KeyOrder> order_;
};

}  // namespace stillmap
