// ORB features spread uniformly over the image, with undistorted coordinates and depth: what the
// tracker matches and estimates poses from.
#pragma once

#include <Eigen/Core>
#include <opencv2/core.hpp>
#include <vector>

#include "stillmap/io/camera.h"
#include "stillmap/io/session_record.h"

namespace stillmap {

struct FeatureOptions {
  int max_features = 1200;  // per frame (ORB-SLAM2's RGB-D setting for 640x480 is 1000)
  int grid_columns = 16;    // the image is cut into cells; each keeps its strongest corners
  int grid_rows = 12;
  int pyramid_levels = 8;
  float scale_factor = 1.2f;
  int fast_threshold = 12;
  // A keypoint gets no depth when its 4x4 depth neighbourhood spreads more than this share of the
  // depth (a depth edge) or has a missing reading.
  double max_depth_spread = 0.03;
  // Opt-in: a keypoint at the depth of a large moving region (a person near the lens) within its
  // descriptor's patch of it is dropped (src/mask_clearance.h): the patch's half-size at the
  // image's scale [px], grown with the keypoint's pyramid level (ORB's patch is 31 px: 15 clears
  // it; 0, the default: only keypoints inside the mask are dropped), and the least size of a
  // region that counts [px]. Off by default: docs/figures.md, forty-first session.
  double mask_clearance_px = 0.0;
  int mask_clearance_min_region_px = 20000;
  // Opt-in: keypoints of pyramid levels 1 and up placed where they lie in the full image. OpenCV's
  // ORB reports them up to 2 px above and left of that (640x480 at 1.2), by an amount that
  // changes with the level; on a corridor that under-estimated the camera's forward motion by
  // 0.3 %. Off by default until the floors' segment joins are settled with it: docs/figures.md,
  // forty-third session.
  bool exact_level_positions = false;

  // Throws InputError naming the first impossible value.
  void Validate() const;

  // Every field under its configuration key (io/option_fields.h).
  template <typename Self, typename Visitor>
  static void VisitFields(Self& self, Visitor& visit) {
    visit("max_features", self.max_features, "ORB features per frame (ORB-SLAM2 RGB-D: 1000)");
    visit("grid_columns", self.grid_columns, "feature grid: cells across the image");
    visit("grid_rows", self.grid_rows, "feature grid: cells down the image");
    visit("pyramid_levels", self.pyramid_levels, "ORB scale pyramid levels");
    visit("scale_factor", self.scale_factor, "ORB scale pyramid: scale between levels");
    visit("fast_threshold", self.fast_threshold, "FAST corner threshold (lower: more corners)");
    visit("max_depth_spread", self.max_depth_spread,
          "keypoints on a depth edge (4x4 spread above this share of depth) get no depth");
    visit("mask_clearance_px", self.mask_clearance_px,
          "keypoints at a large moving region's depth whose ORB patch (this half-size at level 0 "
          "[px], grown per pyramid level) reaches it are dropped (0: off, only those inside the "
          "mask; 15: ORB's patch, for people walking close ahead of the camera)");
    visit("mask_clearance_min_region_px", self.mask_clearance_min_region_px,
          "moving regions smaller than this [px] keep the keypoints beside them (the clearance "
          "above)");
    visit("exact_level_positions", self.exact_level_positions,
          "keypoints of ORB's coarser pyramid levels placed where they lie in the full image "
          "(false: where OpenCV reports them, up to 2 px above and left)");
  }
};

// The features of one frame. Index i refers to the same feature in every vector.
struct FrameFeatures {
  std::vector<cv::KeyPoint> keypoints;      // distorted pixel coordinates, as detected
  cv::Mat descriptors;                      // CV_8U, one 32-byte ORB row per keypoint
  std::vector<Eigen::Vector2d> normalized;  // undistorted normalized coordinates (x/z, y/z)
  std::vector<float> depth_m;               // depth at the keypoint [m], 0 = none

  size_t size() const { return keypoints.size(); }
  // The keypoint's point in the camera frame (requires depth_m[i] > 0).
  Eigen::Vector3d PointInCamera(size_t i) const {
    return depth_m[i] * Eigen::Vector3d(normalized[i].x(), normalized[i].y(), 1.0);
  }
};

// Extracts ORB features from `gray` (CV_8UC1): corners are detected over the whole image, then
// each grid cell keeps its strongest ones (so texture-rich regions cannot take every feature, as
// ORB-SLAM's per-cell extraction intends), and descriptors are computed for the survivors.
// Pixels where `ignore_mask` (CV_8UC1, or empty) is non-zero yield no features, nor do pixels at
// a large moving region's depth whose descriptor patch reaches it (mask_clearance_px).
FrameFeatures ExtractFeatures(const cv::Mat& gray, const cv::Mat& depth_m, const Camera& camera,
                              const cv::Mat& ignore_mask, const FeatureOptions& options);

// A keyframe's features as the session record keeps them (and place links match them).
std::vector<SessionFeature> SessionFeatures(const FrameFeatures& features);

}  // namespace stillmap
