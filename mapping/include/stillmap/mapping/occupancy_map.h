// Probabilistic 3-D occupancy (OctoMap) with ray-cast insertion: each depth reading marks its
// voxel occupied and the voxels along the ray from the camera free.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace stillmap {

struct OccupancyMapOptions {
  bool enabled = true;       // the Mapper builds one (ray casting is the costliest mapping stage)
  double resolution = 0.05;  // leaf voxel edge [m]
  double max_range = 4.0;    // rays are truncated here (free up to it, no hit) [m]; <= 0: none
  double probability_hit = 0.7;  // OctoMap's default sensor model
  double probability_miss = 0.4;
  double clamping_min = 0.1192;  // OctoMap's default clamping thresholds
  double clamping_max = 0.971;
  // Sessions merged into one map (Mapper::BeginLaterSession): a later session's value replaces the
  // earlier ones' where its own evidence weighs at least this many hits (or as many misses).
  double later_session_decisive_hits = 2.0;

  // The log-odds a later session's value must reach to replace the earlier ones'.
  double DecisiveLogOdds() const;

  // Throws InputError naming the first impossible value.
  void Validate() const;

  // Every field under its configuration key (io/option_fields.h).
  template <typename Self, typename Visitor>
  static void VisitFields(Self& self, Visitor& visit) {
    visit("enabled", self.enabled, "build the OctoMap (map.bt, map.ot)");
    visit("resolution", self.resolution, "OctoMap leaf size [m]");
    visit("max_range", self.max_range, "rays truncated at this range [m]; <= 0: none");
    visit("probability_hit", self.probability_hit,
          "sensor model: P(occupied | hit) (OctoMap: 0.7)");
    visit("probability_miss", self.probability_miss,
          "sensor model: P(occupied | pass-through) (OctoMap: 0.4)");
    visit("clamping_min", self.clamping_min, "lower probability clamp (OctoMap: 0.1192)");
    visit("clamping_max", self.clamping_max, "upper probability clamp (OctoMap: 0.971)");
    visit("later_session_decisive_hits", self.later_session_decisive_hits,
          "merge: a later session's voxel replaces the earlier sessions' where its evidence weighs "
          "this many hits (or as many misses)");
  }
};

// Owns an octomap::OcTree (kept out of this header: OctoMap stays in the .cpp).
class OccupancyMap {
 public:
  explicit OccupancyMap(const OccupancyMapOptions& options = {});
  ~OccupancyMap();
  OccupancyMap(OccupancyMap&&) noexcept;
  OccupancyMap& operator=(OccupancyMap&&) noexcept;

  // Inserts one scan: endpoints and the sensor origin in the world frame [m]. Endpoints are first
  // reduced to one per octree voxel (OctoMap's discretized insertion), then rays are cast.
  // Endpoints beyond the tree's extent (see extent()), or all of a scan whose origin lies beyond
  // it, are counted in rejected_count() and left out (OctoMap would print an error for each).
  void InsertScan(const std::vector<Eigen::Vector3f>& points_in_world,
                  const Eigen::Vector3f& sensor_origin_in_world);

  // The map in another frame: each voxel of the new tree takes the value of the old leaf that
  // holds its centre (nearest-neighbour resampling: no holes, known space stays known), and the
  // highest value of the occupied leaves that hold it when they are grown by a quarter voxel
  // (occupied wins: thin walls stay closed, obstacles grow by at most a quarter voxel). Voxels
  // whose centre falls outside the old known space stay unknown; those beyond the extent are
  // left out.
  OccupancyMap Transformed(const Eigen::Isometry3d& new_from_old) const;

  // Lays `later` (the same options; a later observation of the place) over this map: a voxel
  // where `later` is decisive (log-odds at least decisive_log_odds from even) takes its value, a
  // chair moved between two recordings; elsewhere the evidence adds up (clamped).
  void Overlay(const OccupancyMap& later, double decisive_log_odds);

  // Occupancy probability of the leaf at `point_in_world`, or a negative value when unknown.
  double Occupancy(const Eigen::Vector3d& point_in_world) const;

  // Every known leaf: its centre [m], edge length [m] (pruned leaves are larger than the
  // resolution) and whether it is occupied (occupancy probability above 0.5).
  void ForEachLeaf(const std::function<void(const Eigen::Vector3d& centre, double size,
                                            bool occupied)>& visit) const;

  // The tree holds coordinates in (-extent, extent) on each axis [m]: 32767 leaves of the
  // resolution either side of the origin (OctoMap's 16-bit keys), 1638 m at 5 cm.
  double extent() const { return Extent(resolution()); }
  static double Extent(double resolution) { return 32767.0 * resolution; }
  // Endpoints left out because they (or their scan's origin) lay beyond the extent.
  size_t rejected_count() const;

  size_t LeafCount() const;
  size_t OccupiedLeafCount() const;
  size_t MemoryBytes() const;
  double resolution() const;
  double max_range() const;  // OccupancyMapOptions::max_range: rays are truncated there [m]

  // Writes OctoMap's compact binary format (.bt: maximum-likelihood occupied/free only).
  void WriteBinary(const std::string& path) const;
  // Writes OctoMap's full format (.ot: probabilities kept).
  void WriteFull(const std::string& path) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace stillmap
