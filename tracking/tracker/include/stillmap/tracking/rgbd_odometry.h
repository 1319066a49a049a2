// Dense RGB-D odometry: the camera's motion since the last posed frame from every depth reading
// and image gradient, not from features. Point-to-plane ICP with projective association
// (KinectFusion, Newcombe et al. 2011) and a photometric term (Kerl et al., "Robust odometry
// estimation for RGB-D cameras", 2013) in one Gauss-Newton solve, on images averaged over
// cells. With tracking.rgbd_odometry_enabled the tracker falls back on it where features find no
// pose: a blank wall with the floor's tiles in view, a doorway close up. Off by default: on the
// synthetic floor it did not yet make the trajectory better (docs/figures.md, issue 47).
#pragma once

#include <Eigen/Geometry>
#include <opencv2/core.hpp>
#include <vector>

#include "stillmap/io/camera.h"

namespace stillmap {

struct RgbdOdometryOptions {
  bool enabled = false;
  int cell_px = 4;      // the images are averaged over cells of cell_px x cell_px pixels
  int iterations = 20;  // Gauss-Newton iterations at most
  // Pairs farther apart than this are not pairs [m]: the first iteration's bound, halved each
  // iteration down to min_pair_distance_m.
  double max_pair_distance_m = 0.1;
  double min_pair_distance_m = 0.02;
  double max_normal_angle_deg = 30.0;  // between the two frames' normals at a pair
  double max_depth_m = 5.0;            // farther readings are left out (noise grows as z^2)
  // Residual noise: point-to-plane distance [m] and cell intensity (0-1, after each frame's
  // intensities are brought to mean 0.5 and standard deviation 0.2); Huber beyond 2 sigma.
  double sigma_depth_m = 0.003;
  double sigma_intensity = 0.02;
  double min_gradient = 0.01;  // cells whose intensity changes less per cell add no photometry
  // Acceptance: the share of sampled points paired at the end, their RMS point-to-plane
  // distance, the correlation of the two frames' intensities over the textured cells (another view
  // that happens to pair up in depth does not look the same), and the pose's standard deviation
  // along its weakest direction (rotations as the displacement they make at the mean depth) [m]: a
  // wall and a floor without texture leave sliding along them free.
  double min_paired_share = 0.5;
  double max_rmse_m = 0.01;
  double min_intensity_correlation = 0.8;
  double max_weakest_sigma_m = 0.002;
  double max_gap_s = 0.5;      // the reference frame is at most this old
  int keyframe_interval = 10;  // a frame posed this way becomes a keyframe every n frames
  // The check of weak feature poses: a frame whose feature pose has fewer inliers than
  // check_below_inliers is also aligned densely (0: never); where the alignment is taken and
  // the two poses differ by more than check_max_difference_m or check_max_difference_deg, the
  // dense pose replaces the feature pose (floor tiles below a blank wall match a shifted pose).
  // On the synthetic floor, feature poses with 40-60 inliers were off by 10 mm (median) and up
  // to 312 mm frame to frame, the dense ones by 0.3 mm and up to 30 mm (docs/figures.md).
  int check_below_inliers = 120;
  double check_max_difference_m = 0.02;
  double check_max_difference_deg = 1.0;
  // ... and only when at least this many landmarks of the map fit the dense pose (0: always);
  // else the feature pose stays. On the synthetic floor, 20 (as many as a tracked frame needs)
  // stopped an alignment that followed a person over half the image, taken frame after frame
  // with 15 to 1 landmarks fitting, from running 174 mm off in 0.3 s; but in floor_lost's
  // corridor it kept feature poses that followed a person walking ahead (docs/figures.md): off.
  int check_min_landmarks = 0;
  // Only frame to frame: the frame before was posed, at most this long before. After lost frames
  // the motion model is stale and the alignment can settle on a wrong pose (teddy played
  // forward and back, after a blurred stretch) where relocalization found the right one.
  double check_max_gap_s = 0.1;

  // Throws InputError naming the first impossible value.
  void Validate() const;

  // Every field under its configuration key (io/option_fields.h).
  template <typename Self, typename Visitor>
  static void VisitFields(Self& self, Visitor& visit) {
    visit("enabled", self.enabled,
          "pose frames by dense RGB-D alignment to the last posed frame where features find no "
          "pose (off by default: not yet better on the synthetic floor)");
    visit("cell_px", self.cell_px, "images are averaged over square cells this wide [px]");
    visit("iterations", self.iterations, "Gauss-Newton iterations at most");
    visit("max_pair_distance_m", self.max_pair_distance_m,
          "pairs farther apart are left out in the first iteration; halved each one [m]");
    visit("min_pair_distance_m", self.min_pair_distance_m, "... down to this [m]");
    visit("max_normal_angle_deg", self.max_normal_angle_deg,
          "pairs whose normals differ more are left out [deg]");
    visit("max_depth_m", self.max_depth_m, "farther depth readings are left out [m]");
    visit("sigma_depth_m", self.sigma_depth_m, "noise of a point-to-plane distance [m]");
    visit("sigma_intensity", self.sigma_intensity, "noise of a cell's intensity (0-1)");
    visit("min_gradient", self.min_gradient,
          "cells whose intensity changes less per cell add no photometric residual");
    visit("min_paired_share", self.min_paired_share,
          "share of the sampled points paired for the pose to be taken");
    visit("max_rmse_m", self.max_rmse_m, "RMS point-to-plane distance for the pose [m]");
    visit("min_intensity_correlation", self.min_intensity_correlation,
          "correlation of the two frames' intensities over the textured cells for the pose");
    visit("max_weakest_sigma_m", self.max_weakest_sigma_m,
          "the pose's standard deviation along its weakest direction, at most [m]");
    visit("max_gap_s", self.max_gap_s, "the reference frame is at most this old [s]");
    visit("keyframe_interval", self.keyframe_interval,
          "a frame posed this way becomes a keyframe every n frames");
    visit("check_below_inliers", self.check_below_inliers,
          "feature poses with fewer inliers are checked by dense alignment (0: never)");
    visit("check_max_difference_m", self.check_max_difference_m,
          "a checked pose whose camera is farther from the dense one's is replaced by it [m]");
    visit("check_max_difference_deg", self.check_max_difference_deg,
          "... or that is turned more from it [deg]");
    visit("check_min_landmarks", self.check_min_landmarks,
          "... when at least this many map landmarks fit the dense pose (0: always, the default)");
    visit("check_max_gap_s", self.check_max_gap_s,
          "a pose is checked only when the frame before was posed at most this long before [s]");
  }
};

// The result of one alignment, and why it was refused when it was.
struct RgbdAlignment {
  enum class Verdict { kOk, kFewPairs, kLoose, kUnconstrained };
  Verdict verdict = Verdict::kFewPairs;
  Eigen::Isometry3d reference_from_current = Eigen::Isometry3d::Identity();
  int sampled = 0;      // current-frame cells with usable depth
  int paired = 0;       // of them, paired in the last iteration
  int textured = 0;     // photometric residuals in the last iteration
  double rmse_m = 0.0;  // RMS point-to-plane distance
  // Correlation of the two frames' intensities over the textured cells (1 when there are none).
  double intensity_correlation = 1.0;
  double weakest_sigma_m = 0.0;
  bool ok() const { return verdict == Verdict::kOk; }
};

// The rays and projection of a camera's images reduced to cells of cell_px x cell_px pixels,
// computed once (distortion included).
class CellCamera {
 public:
  CellCamera(const Camera& camera, int cell_px);
  const Camera& camera() const { return camera_; }  // the reduced images' camera
  int cell_px() const { return cell_px_; }
  const Eigen::Vector2f& Ray(int u, int v) const {
    return rays_[static_cast<size_t>(v) * static_cast<size_t>(camera_.width) +
                 static_cast<size_t>(u)];
  }
  Eigen::Vector2f Project(const Eigen::Vector3f& point) const {
    return projection_(point.x() / point.z(), point.y() / point.z());
  }

 private:
  Camera camera_;
  int cell_px_;
  std::vector<Eigen::Vector2f> rays_;
  PixelProjection projection_;
};

// One frame's images: gray (CV_8U), depth (CV_32F metres) and the mask of pixels to leave out
// (CV_8U, non-zero; may be empty). Full size.
struct RgbdImages {
  cv::Mat gray, depth_m, ignore_mask;
};

// Aligns the current frame to the reference one, from `initial` (reference_from_current, e.g.
// the motion model's). `camera` must be made with options.cell_px.
RgbdAlignment AlignRgbd(const CellCamera& camera, const RgbdImages& reference,
                        const RgbdImages& current, const Eigen::Isometry3d& initial,
                        const RgbdOdometryOptions& options);

}  // namespace stillmap
