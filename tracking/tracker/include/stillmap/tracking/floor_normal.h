// The floor a ground robot's camera sees, as the camera's up: the floor's normal in the camera's
// frame is the direction the camera sees up along, fixed by its mount. tracking.planar_motion
// takes the camera's tilt from its tracked poses (their mean), and the tracked tilt carries the
// tracking's own bias: on the synthetic floors the final poses saw up 0.06-0.25 degrees off, the
// same in every keyframe, where the floor in their depth gave it within 0.01 degrees
// (docs/figures.md, seventy-fourth session). A tilt so small moves a point 2.5 m away by 3-11 mm,
// and differently for each heading, so the map's floor and walls blur.
//
// In one depth image the floor is the lowest layer of readings along the pose's up that holds a
// fair share of them; a plane fitted there (least squares, refined on the readings near it) is
// the floor when it lies within a few degrees of level. Over many keyframes the median direction
// is the mount's up.
#pragma once

#include <Eigen/Core>
#include <opencv2/core.hpp>
#include <optional>
#include <vector>

namespace stillmap {

struct FloorNormalOptions {
  bool enabled = true;       // the plane of motion takes the camera's tilt from the floor it sees
  int stride_px = 4;         // readings sampled every n pixels along rows and columns
  double max_depth_m = 4.0;  // farther readings are left out (Kinect noise grows as z^2) [m]
  // The floor is looked for in the lowest layer this thick along the pose's up [m] ...
  double layer_m = 0.05;
  double min_layer_share = 0.05;  // ... that holds at least this share of the sampled readings
  double inlier_m = 0.01;         // readings this near the plane refine it [m]
  int min_points = 300;           // a floor of fewer sampled readings is not taken
  double max_angle_deg = 3.0;     // a plane tilted more from the pose's up is not the floor [deg]
  // At most this many of the map's keyframes are read (spread evenly over them), and at least
  // this many must see the floor for its up to be taken.
  int max_keyframes = 300;
  int min_keyframes = 10;

  // Throws InputError naming the first impossible value.
  void Validate() const;

  // Every field under its configuration key (io/option_fields.h).
  template <typename Self, typename Visitor>
  static void VisitFields(Self& self, Visitor& visit) {
    visit("enabled", self.enabled,
          "the plane of motion takes the camera's tilt from the floor its keyframes see in "
          "depth, not from the tracked poses");
    visit("stride_px", self.stride_px, "depth readings sampled every n pixels");
    visit("max_depth_m", self.max_depth_m, "farther readings are left out [m]");
    visit("layer_m", self.layer_m,
          "the floor is looked for in the lowest layer this thick along the pose's up [m]");
    visit("min_layer_share", self.min_layer_share,
          "... holding at least this share of the sampled readings");
    visit("inlier_m", self.inlier_m, "readings this near the fitted plane refine it [m]");
    visit("min_points", self.min_points, "a floor of fewer sampled readings is not taken");
    visit("max_angle_deg", self.max_angle_deg,
          "a plane tilted more from the pose's up is not the floor [deg]");
    visit("max_keyframes", self.max_keyframes, "keyframes read at most (spread evenly)");
    visit("min_keyframes", self.min_keyframes,
          "keyframes that must see the floor for its up to be taken");
  }
};

// The floor's unit normal in the camera's frame, pointing up (towards the camera), from a depth
// image [m] (0: no reading; moving pixels already 0) whose pixels' undistorted normalized rays
// are `rays` (PixelRays, row-major); `up_in_camera` is the pose's guess of up. Nothing when no
// level plane holds enough readings (a wall close up, a view of the ceiling).
std::optional<Eigen::Vector3d> FloorNormalInCamera(const std::vector<Eigen::Vector2f>& rays,
                                                   const cv::Mat& depth_m,
                                                   const Eigen::Vector3d& up_in_camera,
                                                   const FloorNormalOptions& options);

// The median direction of unit vectors (each coordinate's median, normalized): a few keyframes
// that took a ramp or a sloped surface for the floor move it little. Nothing for none.
std::optional<Eigen::Vector3d> MedianDirection(const std::vector<Eigen::Vector3d>& directions);

}  // namespace stillmap
