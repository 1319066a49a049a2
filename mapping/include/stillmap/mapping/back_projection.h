// Depth back-projection: every valid depth pixel to a colored 3-D point in the world frame.
#pragma once

#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <opencv2/core.hpp>
#include <vector>

#include "stillmap/io/camera.h"

namespace stillmap {

struct BackProjectionOptions {
  double min_depth = 0.1;
  double max_depth = 4.0;  // readings farther than this are ignored [m] (Kinect-class noise grows
                           // with the square of depth; beyond 4 m it exceeds a 1 cm voxel)
  int pixel_stride = 1;
  // Edge-preserving depth smoothing before back-projection: each reading is replaced by the mean
  // (in inverse depth: exact on planes) of the readings within this many pixels that lie within
  // 3 sigma(z) of it, sigma(z) = 1.2 mm +
  // 1.9 mm (z - 0.4 m)^2, the Kinect's axial noise (Nguyen et al., 3DIMPVT 2012). 0 = off.
  int smoothing_radius = 2;

  // Throws InputError naming the first impossible value.
  void Validate() const;

  // Every field under its configuration key (io/option_fields.h).
  template <typename Self, typename Visitor>
  static void VisitFields(Self& self, Visitor& visit) {
    visit("min_depth", self.min_depth, "depth readings nearer are ignored [m]");
    visit("max_depth", self.max_depth, "depth readings farther are ignored [m]");
    visit("pixel_stride", self.pixel_stride, "back-project every n-th pixel along u and v");
    visit("smoothing_radius", self.smoothing_radius,
          "edge-preserving depth smoothing radius [px] (0 = off; noise model: Nguyen et al. 2012)");
  }
};

// Colored points, structure of arrays (the hot loops touch positions and colors separately).
struct ColoredPoints {
  std::vector<Eigen::Vector3f> positions;           // [m], frame given by the producer
  std::vector<std::array<std::uint8_t, 3>> colors;  // R, G, B

  void Clear() {
    positions.clear();
    colors.clear();
  }
  size_t size() const { return positions.size(); }
};

// Back-projects depth images of one camera. The undistorted viewing ray of every pixel is computed
// once: with zero distortion it is ((u - cx) / fx, (v - cy) / fy, 1), so a reading z gives
// P = z * ray, paper 000 eq. (12); with distortion, OpenCV's undistortPoints gives the ray.
class DepthBackProjector {
 public:
  DepthBackProjector(const Camera& camera, const BackProjectionOptions& options);

  // Appends to `out` the points of `depth_m` (CV_32FC1, metres, 0 = none) within the depth range,
  // colored from `color` (CV_8UC3 BGR, same size; or empty for positions only, `out->colors`
  // then untouched), skipping pixels where `mask` (CV_8UC1, or empty for none) is non-zero,
  // transformed by `world_from_camera`.
  void BackProject(const cv::Mat& depth_m, const cv::Mat& color, const cv::Mat& mask,
                   const Eigen::Isometry3f& world_from_camera, ColoredPoints* out) const;

  // The undistorted normalized ray (x, y) of pixel (u, v): P = z * (x, y, 1).
  Eigen::Vector2f Ray(int u, int v) const;

 private:
  int width_;
  int height_;
  BackProjectionOptions options_;
  std::vector<float> ray_x_;  // per pixel, row-major
  std::vector<float> ray_y_;
  mutable cv::Mat smoothed_;  // scratch for the smoothed depth
};

// The edge-preserving smoothing of BackProjectionOptions::smoothing_radius, on its own.
void SmoothDepth(const cv::Mat& depth_m, int radius, cv::Mat* smoothed);

}  // namespace stillmap
