// The mapping back-end: frames with known poses in, voxel cloud and OctoMap out.
#pragma once

#include <Eigen/Geometry>
#include <atomic>
#include <future>
#include <memory>
#include <mutex>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "stillmap/io/camera.h"
#include "stillmap/mapping/back_projection.h"
#include "stillmap/mapping/map_cleaning.h"
#include "stillmap/mapping/occupancy_map.h"
#include "stillmap/mapping/voxel_cloud.h"

namespace stillmap {

struct MapperOptions {
  BackProjectionOptions back_projection;
  VoxelCloudOptions voxel;
  OccupancyMapOptions occupancy;
  MapCleaningOptions cleaning;
  // Fuse on worker threads: the caller hands a frame over and goes on (tracking the next frames),
  // and the OctoMap insertion of one frame overlaps the voxelization of the next (the two stages
  // cost about the same). On bonn_crowd_a this takes 2.6 ms per frame off the tracking thread.
  bool in_background = true;
  // A build whose cleaned map holds fewer points fails (exit 1) instead of writing files that
  // look like a result: 1000 points of 1 cm cover 0.1 m^2, less than one frame of a wall at 3 m.
  int min_map_points = 1000;
  void Validate() const;
  // The maps hold points within +-Extent() of the origin on every axis [m] (the voxel cloud's and,
  // when enabled, the OctoMap's key range).
  double Extent() const;

  // Every field under its configuration key (io/option_fields.h).
  template <typename Self, typename Visitor>
  static void VisitFields(Self& self, Visitor& visit) {
    visit.Nested("", self.back_projection);
    visit.Nested("voxel_", self.voxel);
    visit.Section("octomap", self.occupancy);
    visit.Nested("", self.cleaning);
    visit("in_background", self.in_background,
          "fuse on worker threads while tracking goes on (false: on the calling thread)");
    visit("min_map_points", self.min_map_points,
          "fewer points in the cleaned map fail the build (exit 1): a near-empty map is no result");
  }
};

// One frame to fuse: images as decoded by io, a mask of pixels to leave out (CV_8UC1, non-zero =
// excluded, or empty) and the camera's final pose.
struct MapperFrame {
  double time = 0.0;  // [s]
  cv::Mat color;      // CV_8UC3 BGR; may be empty in a rays-only frame
  cv::Mat depth_m;    // CV_32FC1 [m]
  cv::Mat mask;       // CV_8UC1 or empty
  Eigen::Isometry3d world_from_camera = Eigen::Isometry3d::Identity();
  // Only its rays go into the map (the OctoMap's free space and hits), no points into the cloud
  // and no view for the cleaning: a keyframe that adds nothing new still clears what moved away
  // (the cleaning reads the OctoMap too). Its view would cost 150 KB at 640 x 480, and took no
  // more ghosts away on the floor (docs/figures.md).
  bool rays_only = false;
  // The moving pixels alone when `mask` also leaves out cells fused before (the grid's views
  // take every static ray); empty: `mask` is the moving pixels.
  cv::Mat moving_mask;
};

// Totals over all fused frames.
struct MapperStatistics {
  size_t frames = 0;            // frames fused
  size_t rays_only_frames = 0;  // frames of which only the rays went in (MapperFrame::rays_only)
  size_t points = 0;            // back-projected points fused
  double back_projection_ms = 0.0;
  double voxel_ms = 0.0;
  double occupancy_ms = 0.0;       // OctoMap insertion, on whichever thread ran it
  double occupancy_wait_ms = 0.0;  // time fusion waited for the previous OctoMap insertion
  double wait_ms = 0.0;            // time the caller waited for background fusion
  // CPU time of the fusion and OctoMap jobs that ran on their own threads (in_background).
  double background_cpu_ms = 0.0;
  size_t refusions = 0;  // times the map was emptied to be fused again (Reset)
};

// What a Mapper holds [bytes], for the run report's memory breakdown: as of the last frame fused
// (the OctoMap's as of its last count, every 16th insertion: counting walks the tree).
struct MapperMemory {
  size_t voxel_cloud = 0;  // the voxel table (VoxelCloud::MemoryBytes)
  size_t occupancy = 0;    // the OctoMap's nodes (OccupancyMap::MemoryBytes)
  size_t views = 0;        // the fused frames' views kept for the map cleaning and the grid
};

// The map a Mapper built, handed out once by Mapper::Finish.
struct FinishedMap {
  VoxelCloud cloud;
  std::unique_ptr<OccupancyMap> occupancy;  // null when occupancy.enabled is false
  MapperStatistics statistics;
  std::vector<KeyframeView> views;  // of the fused frames, for the map cleaning
  std::vector<Camera> cameras;      // the views' cameras (KeyframeView::camera)
  // Of the fused frames' whole depth, at a quarter resolution, for the grid (Mapper's
  // keep_grid_views).
  std::vector<KeyframeView> grid_views;

  // Cleans the cloud (MapCleaningOptions) against the OctoMap and the views; call once, before
  // the cloud is written. Reads the OctoMap only, so it may run while the OctoMap is written.
  MapCleaningResult CleanCloud(const MapCleaningOptions& options);
  // Writes map.ply/map.pcd of the cloud (tests; the pipeline writes the points it took out).
  void WriteCloud(const std::string& ply_path, const std::string& pcd_path) const;
  // The cleaned cloud's points (VoxelCloud::TakePoints), the views freed before they are made
  // and the voxel table after: the files are written from those points, and the mesh is made
  // while the map files are written (the floor's peak, 4.4 GiB with all still held). The OctoMap
  // stays.
  std::vector<VoxelPoint> TakeCloudPoints();
  // Writes map.bt/map.ot when there is an OctoMap.
  void WriteOccupancy(const std::string& bt_path, const std::string& ot_path) const;
};

class Mapper {
 public:
  // keep_grid_views: keep a quarter-resolution view of each fused frame's whole depth (its
  // moving pixels left out, not the cells fused before) for FinishedMap::grid_views: the grid's
  // unseen layers (GridOptions::min_unseen_layer_m) need every ray.
  Mapper(const Camera& camera, const MapperOptions& options, bool keep_grid_views = false);
  ~Mapper();
  Mapper(const Mapper&) = delete;
  Mapper& operator=(const Mapper&) = delete;

  // Back-projects the frame's unmasked depth and fuses it into the voxel cloud and the OctoMap
  // (the camera center is the origin of every ray). In the background, the frame's images are
  // shared, not copied: the caller must not write to them afterwards.
  void Integrate(const MapperFrame& frame);

  // Empties the map (cloud, OctoMap, views) so that the frames can be fused again at corrected
  // poses (loop closure); waits for the background work first. Timings add up; frames and
  // points count again from zero, and refusions counts the calls.
  void Reset();

  // The frames from here on observe the place later than those before (another recording, when
  // sessions are merged): where they are decisive they replace what the earlier frames said
  // (OctoMap leaves, OccupancyMapOptions::later_session_decisive_hits; the view cleaning), so a
  // chair moved between recordings stands where it was seen last, and its old place is free.
  // The later session's frames come from `camera` (another camera, or the same).
  void BeginLaterSession(const Camera& camera);
  // Waits for the background work still running (rethrowing its failure) and hands over the
  // map. Call once: the mapper holds nothing afterwards (a second call throws
  // std::logic_error), so the finished map has one owner on whatever thread uses it.
  FinishedMap Finish();

  const MapperOptions& options() const { return options_; }
  // Safe to call from any thread while frames are fused.
  MapperMemory memory() const;

 private:
  MapperOptions options_;
  bool keep_grid_views_ = false;
  DepthBackProjector projector_;
  VoxelCloud cloud_;
  std::unique_ptr<OccupancyMap> occupancy_;  // of the current session
  std::unique_ptr<OccupancyMap> earlier_;    // of the sessions before it (BeginLaterSession)
  int session_ = 0;
  ColoredPoints scratch_;
  Camera camera_;
  std::vector<Camera> cameras_;                    // every camera so far; camera_ is the last
  std::vector<KeyframeView> views_;                // of the fused frames, for the cleaning
  std::vector<KeyframeView> grid_views_;           // for the grid (keep_grid_views)
  std::vector<Eigen::Vector3f> occupancy_points_;  // owned by the background insertion
  void Fuse(const MapperFrame& frame);             // on the fusion thread in the background
  void WaitForOccupancy();
  void WaitForFusion();
  void AddBackgroundCpu(double ms);  // from either job's thread
  bool finished_ = false;

  void CountOccupancyBytes();  // after an insertion, on its thread
  // memory(): set by the jobs, read by any thread.
  std::atomic<size_t> voxel_bytes_{0}, occupancy_bytes_{0}, views_bytes_{0};
  size_t insertions_ = 0;  // OctoMap insertions, on the insertion's thread

  std::future<void> fusion_job_;     // back-projection and voxels of the last frame handed over
  std::future<void> occupancy_job_;  // its OctoMap insertion (started by the fusion job)
  MapperStatistics statistics_;
  std::mutex cpu_mutex_;  // statistics_.background_cpu_ms, added to by both jobs
};

}  // namespace stillmap
