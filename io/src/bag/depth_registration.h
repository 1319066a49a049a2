// Depth recorded in a camera of its own (a depth topic whose CameraInfo differs from colour's)
// registered into the colour camera, as realsense2_camera's align_depth does: each depth pixel's
// footprint, back-projected with the depth camera (its distortion undone) and moved into the
// colour optical frame by the transform /tf_static gives, is drawn where it projects in the
// colour image (the colour camera's distortion applied), the nearest surface kept.
#pragma once

#include <Eigen/Geometry>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "bag/ros_messages.h"

namespace stillmap {

class DepthRegistration {
 public:
  // `color_from_depth`: the depth optical frame's pose in the colour optical frame. Throws
  // InputError naming `where` for a distortion model it cannot apply.
  DepthRegistration(const RosCameraInfo& depth, const RosCameraInfo& color,
                    const Eigen::Isometry3d& color_from_depth, const std::string& where);
  // `depth_m` (CV_32FC1 [m], the depth camera's size; 0 = no reading) as the colour camera sees
  // it: CV_32FC1 of the colour camera's size, 0 where no depth pixel lands. Throws InputError
  // naming `where` for depth of another size than its CameraInfo says.
  cv::Mat Register(const cv::Mat& depth_m, const std::string& where) const;

 private:
  // Colour pixel coordinates of a point in the colour optical frame (z > 0).
  cv::Point2f Project(const Eigen::Vector3f& point) const;

  int depth_width_, depth_height_, color_width_, color_height_;
  cv::Mat corner_rays_;  // (h+1) x (w+1) CV_32FC2: x/z, y/z of each depth pixel corner
  Eigen::Matrix3f rotation_;
  Eigen::Vector3f translation_;
  float fx_, fy_, cx_, cy_;
  std::array<float, 8> distortion_{};  // colour camera's k1 k2 p1 p2 k3 k4 k5 k6
};

// The transform as an isometry: a point of `child` mapped into `parent`.
Eigen::Isometry3d IsometryOf(const RosTransform& transform);

// The pose of frame `source` in frame `target` from static transforms, chained through the
// frames they share in either direction (tf's tree); none when they do not link the two.
std::optional<Eigen::Isometry3d> FindStaticTransform(const std::vector<RosTransform>& transforms,
                                                     const std::string& target,
                                                     const std::string& source);

}  // namespace stillmap
