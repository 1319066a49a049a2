// Multi-view depth check (paper 002, RTD-SLAM, section III.A): points of a reference keyframe,
// placed in 3-D with their depth, are projected into the current frame. Where the current depth
// reading at the projection is nearer than the projected depth by more than tau_d, something
// stands in front of where the static point should be: the current pixel is dynamic. Points seen
// under a parallax angle above 30 degrees are skipped (paper 002: on TUM, static points looked
// dynamic beyond that, from the change of viewpoint alone).
#pragma once

#include <Eigen/Geometry>
#include <opencv2/core.hpp>
#include <vector>

#include "stillmap/io/camera.h"

namespace stillmap {

struct DepthCheckOptions {
  double max_depth_difference_m = 0.4;  // tau_d, paper 002
  double max_parallax_deg = 30.0;       // paper 002

  // Every field under its configuration key (io/option_fields.h).
  template <typename Self, typename Visitor>
  static void VisitFields(Self& self, Visitor& visit) {
    visit("max_depth_difference_m", self.max_depth_difference_m,
          "tau_d: nearer than the keyframe's static depth by this [m] (paper 002: 0.4)");
    visit("max_parallax_deg", self.max_parallax_deg,
          "depth-check points seen under more parallax are skipped [deg] (paper 002: 30)");
  }
};

enum class DepthVerdict { kStatic, kDynamic, kSkipped };

struct DepthCheck {
  DepthVerdict verdict = DepthVerdict::kSkipped;
  cv::Point2f pixel;               // projection in the current image (distorted pixels)
  double projected_depth_m = 0.0;  // the reference point's depth in the current camera
  double measured_depth_m = 0.0;   // the current depth reading there (0 = none)
  double parallax_deg = 0.0;
};

// points_in_reference: 3-D points in the reference camera frame; current_from_reference: the
// current camera's pose relative to the reference camera; current_depth_m: CV_32FC1 [m].
// Skipped: behind the camera, outside the image, no reading, or parallax above the limit.
std::vector<DepthCheck> CheckDepth(const std::vector<Eigen::Vector3d>& points_in_reference,
                                   const Eigen::Isometry3d& current_from_reference,
                                   const cv::Mat& current_depth_m, const Camera& camera,
                                   const DepthCheckOptions& options = {});

}  // namespace stillmap
