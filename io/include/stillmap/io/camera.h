// Pinhole RGB-D camera with OpenCV radial-tangential distortion, the depth scale of its PNGs and,
// for motion-capture ground truth, the pose of the camera in the tracked body.
#pragma once

#include <Eigen/Geometry>
#include <array>
#include <optional>
#include <string>
#include <vector>

namespace stillmap {

// Intrinsics of a color camera whose depth images are registered to it (TUM/Bonn convention: a
// depth pixel (u, v) belongs to color pixel (u, v)).
struct Camera {
  static constexpr int kMaxImageSide = 8192;  // largest accepted width or height [px]

  int width = 640;                     // image width [px]
  int height = 480;                    // image height [px]
  double fx = 0.0;                     // focal length along x [px]
  double fy = 0.0;                     // focal length along y [px]
  double cx = 0.0;                     // principal point x [px]
  double cy = 0.0;                     // principal point y [px]
  std::array<double, 5> distortion{};  // OpenCV k1 k2 p1 p2 k3
  // OpenCV's rational model k4 k5 k6 (ROS rational_polynomial, e.g. Azure Kinect's CameraInfo):
  // the radial factor's denominator 1 + k4 r^2 + k5 r^4 + k6 r^6. Zero for plumb_bob.
  std::array<double, 3> rational{};
  double depth_factor = 5000.0;  // depth PNG value per metre
  // When set, groundtruth.txt gives the pose of a motion-capture body, and
  // world_from_camera = world_from_body * body_from_camera (the Bonn sequences need it).
  std::optional<Eigen::Isometry3d> groundtruth_body_from_camera;

  // True when any distortion coefficient is non-zero.
  bool HasDistortion() const;
  // The coefficients as OpenCV takes them: k1 k2 p1 p2 k3, then k4 k5 k6 when any is non-zero.
  std::vector<double> Coefficients() const;
  // Throws InputError naming `source` and the first impossible value.
  void Validate(const std::string& source) const;
};

// Axial depth noise of Kinect-class sensors at depth z [m] (Nguyen et al., 3DIMPVT 2012).
inline float KinectDepthSigma(float z) { return 0.0012f + 0.0019f * (z - 0.4f) * (z - 0.4f); }

// The undistorted normalized ray (x, y) of every pixel, row-major: OpenCV's undistortPoints with
// the camera's distortion, or (u - cx) / fx, (v - cy) / fy without.
std::vector<Eigen::Vector2f> PixelRays(const Camera& camera);

// Normalized coordinates to pixel coordinates with the camera's distortion, in float for
// per-pixel loops (the coefficients are converted once).
class PixelProjection {
 public:
  explicit PixelProjection(const Camera& camera);

  // The pixel position (u, v), not rounded, of normalized (x, y).
  Eigen::Vector2f operator()(float x, float y) const {
    if (distorted_) {
      const float r2 = x * x + y * y;
      const float radial =
          (1.0f + r2 * (k1_ + r2 * (k2_ + r2 * k3_))) / (1.0f + r2 * (k4_ + r2 * (k5_ + r2 * k6_)));
      const float xd = x * radial + 2.0f * p1_ * x * y + p2_ * (r2 + 2.0f * x * x);
      const float yd = y * radial + p1_ * (r2 + 2.0f * y * y) + 2.0f * p2_ * x * y;
      x = xd;
      y = yd;
    }
    return {fx_ * x + cx_, fy_ * y + cy_};
  }

 private:
  float fx_, fy_, cx_, cy_;
  float k1_, k2_, p1_, p2_, k3_, k4_, k5_, k6_;
  bool distorted_;
};

// Names of the built-in presets: tum1, tum2, tum3, bonn, ros_default.
std::vector<std::string> CameraPresetNames();
// The same names joined with '|', for messages and help texts.
std::string CameraPresetChoices();

// The calibration of a built-in preset (TUM freiburg1/2/3 from the benchmark's published
// calibration, the Bonn Xtion, and the undistorted ROS default fx=fy=525). Throws InputError for
// an unknown name, listing the known ones.
Camera CameraPreset(const std::string& name);

// Reads a camera.yaml (keys width, height, fx, fy, cx, cy, distortion, depth_factor and the
// optional groundtruth_body_from_camera, row-major 4x4). A missing or malformed key, or an unknown
// one, is an InputError naming the file and the key.
Camera LoadCameraYaml(const std::string& path);

// Writes `camera` as a camera.yaml that LoadCameraYaml reads back. Throws std::runtime_error when
// the file cannot be written.
void WriteCameraYaml(const std::string& path, const Camera& camera, const std::string& comment);

}  // namespace stillmap
