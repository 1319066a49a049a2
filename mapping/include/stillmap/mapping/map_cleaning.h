// Clean-up of the finished voxel cloud: voxels the OctoMap's rays later saw through (whatever
// stood there moved away) and, optionally, PCL's statistical outliers.
#pragma once

#include <Eigen/Geometry>
#include <cstddef>
#include <memory>
#include <opencv2/core.hpp>
#include <vector>

#include "stillmap/io/camera.h"
#include "stillmap/io/mapped_pages.h"
#include "stillmap/mapping/occupancy_map.h"
#include "stillmap/mapping/voxel_cloud.h"

namespace stillmap {

struct MapCleaningOptions {
  // Drop cloud voxels whose OctoMap leaf ends free: later rays passed through the place, so what
  // was fused there has gone (a person the mask missed in one keyframe). Needs the OctoMap.
  bool clear_seen_through = true;
  // The same at the cloud's resolution, against the fused keyframes' own depth: a voxel that at
  // least min_free_views keyframes saw *through* (their reading along its ray lies farther than
  // it by more than view_margin_m + view_margin_sigmas sigma of Kinect noise), more than
  // free_view_ratio times as many as saw it there, is dropped. It catches what an OctoMap leaf
  // shared with the floor keeps (a shoe on the floor for one keyframe).
  bool clear_seen_through_views = true;
  int min_free_views = 2;
  double free_view_ratio = 2.0;
  double view_margin_m = 0.02;  // [m]
  double view_margin_sigmas = 3.0;
  // PCL StatisticalOutlierRemoval: a voxel whose mean distance to its outlier_neighbors nearest
  // voxels exceeds the cloud's mean of that distance by outlier_std_ratio standard deviations.
  bool outlier_removal = false;
  int outlier_neighbors = 16;
  double outlier_std_ratio = 2.0;

  // Throws InputError naming the first impossible value.
  void Validate() const;

  // Every field under its configuration key (io/option_fields.h).
  template <typename Self, typename Visitor>
  static void VisitFields(Self& self, Visitor& visit) {
    visit("clear_seen_through", self.clear_seen_through,
          "drop cloud voxels the OctoMap ends up calling free (later rays saw through them)");
    visit("clear_seen_through_views", self.clear_seen_through_views,
          "drop cloud voxels that fused keyframes saw through, at the cloud's resolution");
    visit("min_free_views", self.min_free_views,
          "view cleaning: keyframes that must have seen through a voxel");
    visit("free_view_ratio", self.free_view_ratio,
          "view cleaning: keyframes seeing through a voxel outnumber those seeing it this often");
    visit("view_margin_m", self.view_margin_m,
          "view cleaning: a reading farther by this [m] + view_margin_sigmas sees through");
    visit("view_margin_sigmas", self.view_margin_sigmas,
          "view cleaning: Kinect noise sigmas added to view_margin_m");
    visit("outlier_removal", self.outlier_removal, "PCL statistical outlier removal on the cloud");
    visit("outlier_neighbors", self.outlier_neighbors,
          "outlier removal: neighbours averaged per voxel");
    visit("outlier_std_ratio", self.outlier_std_ratio,
          "outlier removal: voxels this many standard deviations above the mean distance go");
  }
};

// A fused keyframe as the view check needs it: its depth at half resolution (the nearest reading
// of each 2 x 2 block; 0 where any of the block is masked) and its pose. The grid's unseen layers
// take views of coarser blocks (`block`). The depth is kept in 16
// bits, in steps of its largest reading / 65535 (0.1 mm at 6.5 m, far below the check's margin):
// the views of a long recording add up.
struct KeyframeView {
  cv::Mat depth;  // CV_16UC1, (width + 1) / 2 x (height + 1) / 2, 0 = no reading or masked
  // What `depth` lies in when MakeKeyframeView made it: pages of its own, handed back to the system
  // with the last copy (views live through the frame loop and are freed before the map's points
  // are made, which could not use the holes they would leave in the heap).
  std::shared_ptr<MappedArray<std::uint16_t>> pages;
  float depth_unit_m = 0.0f;  // the step of `depth` [m]
  Eigen::Isometry3f camera_from_world = Eigen::Isometry3f::Identity();
  // Merged sessions (Mapper::BeginLaterSession): of a voxel, only the latest session that saw it
  // or saw through it is heard.
  int session = 0;
  int camera = 0;  // index of its camera in CleanCloud's `cameras`
  int block = 2;   // each reading stands for a block this many pixels wide and high

  // The reading of block (row, col) [m], 0 = none.
  float Reading(int row, int col) const {
    return static_cast<float>(depth.at<std::uint16_t>(row, col)) * depth_unit_m;
  }
  // Bytes it holds.
  size_t MemoryBytes() const { return sizeof(KeyframeView) + depth.total() * depth.elemSize(); }
};

// The view of a frame: depth_m (CV_32FC1) and mask (CV_8UC1 or empty) at full resolution, in
// blocks of `block` x `block` pixels (the map cleaning's: 2).
KeyframeView MakeKeyframeView(const cv::Mat& depth_m, const cv::Mat& mask,
                              const Eigen::Isometry3d& world_from_camera, int block = 2);

struct MapCleaningResult {
  size_t seen_through = 0;        // voxels removed because the OctoMap calls their place free
  size_t seen_through_views = 0;  // voxels removed because keyframes saw through them
  size_t outliers = 0;            // voxels removed as statistical outliers
};

// Removes the voxels named above from `cloud` (occupancy may be null: no see-through check;
// views may be empty: no view check; `cameras` are the views' cameras, by KeyframeView::camera).
MapCleaningResult CleanCloud(const MapCleaningOptions& options, const OccupancyMap* occupancy,
                             const std::vector<Camera>& cameras,
                             const std::vector<KeyframeView>& views, VoxelCloud* cloud);

}  // namespace stillmap
