// Dense RGB-D odometry against exact ray-cast frames: planes (a room's corner, a corridor's end)
// seen from two poses whose motion is known. Where the geometry or the texture pins every degree
// of freedom the motion must come back to a fraction of a millimetre; blank planes that leave
// sliding along them free must be refused, not given a pose.
#include "stillmap/tracking/rgbd_odometry.h"

#include <gtest/gtest.h>

#include <random>

namespace stillmap {
namespace {

struct Plane {
  Eigen::Vector3d normal;  // n . p = offset, in the reference camera's frame
  double offset;
  bool tiled = false;  // 30 cm tiles with dark 1 cm joints, else blank
};

// Undistorted, fx = fy = 525 px, 640 x 480.
Camera TestCamera() { return CameraPreset("ros_default"); }

// The gray level of a plane at `point`: blank, or tiles whose joints run along the plane's two
// other axes.
std::uint8_t Shade(const Plane& plane, const Eigen::Vector3d& point) {
  if (!plane.tiled) return 180;
  for (int axis = 0; axis < 3; ++axis) {
    if (std::abs(plane.normal[axis]) > 0.5) continue;
    const double along = std::fmod(std::abs(point[axis]) + 10.0, 0.3);
    if (along < 0.01) return 60;
  }
  return 200;
}

// What a camera at `reference_from_camera` sees of `planes`: depth (with Gaussian noise of
// `sigma_m` when positive) and gray.
RgbdImages RayCast(const std::vector<Plane>& planes, const Eigen::Isometry3d& reference_from_camera,
                   double sigma_m = 0.0) {
  const Camera camera = TestCamera();
  std::mt19937 random(7);
  std::normal_distribution<double> noise(0.0, sigma_m > 0.0 ? sigma_m : 1.0);
  RgbdImages images;
  images.depth_m = cv::Mat(camera.height, camera.width, CV_32F, cv::Scalar(0.0));
  images.gray = cv::Mat(camera.height, camera.width, CV_8U, cv::Scalar(0));
  const Eigen::Vector3d origin = reference_from_camera.translation();
  for (int v = 0; v < camera.height; ++v) {
    for (int u = 0; u < camera.width; ++u) {
      const Eigen::Vector3d ray((u - camera.cx) / camera.fx, (v - camera.cy) / camera.fy, 1.0);
      const Eigen::Vector3d direction = reference_from_camera.linear() * ray;
      double nearest = 0.0;
      const Plane* seen = nullptr;
      for (const Plane& plane : planes) {
        const double along = plane.normal.dot(direction);
        if (std::abs(along) < 1e-9) continue;
        const double s = (plane.offset - plane.normal.dot(origin)) / along;
        if (s > 0.0 && (seen == nullptr || s < nearest)) {
          nearest = s;
          seen = &plane;
        }
      }
      if (seen == nullptr) continue;
      images.depth_m.at<float>(v, u) =
          static_cast<float>(nearest + (sigma_m > 0.0 ? noise(random) : 0.0));
      images.gray.at<std::uint8_t>(v, u) = Shade(*seen, origin + nearest * direction);
    }
  }
  return images;
}

// Floor 0.6 m below (y down), an end wall 2.5 m ahead, a side wall 0.9 m to the right.
std::vector<Plane> Corner() {
  return {{Eigen::Vector3d::UnitY(), 0.6},
          {Eigen::Vector3d::UnitZ(), 2.5},
          {Eigen::Vector3d::UnitX(), 0.9}};
}

// A blank end wall 1.8 m ahead over a floor 0.6 m below, tiled or not: nothing but the tiles
// pins sliding along the wall.
std::vector<Plane> WallOverFloor(bool tiled) {
  return {{Eigen::Vector3d::UnitY(), 0.6, tiled}, {Eigen::Vector3d::UnitZ(), 1.8}};
}

Eigen::Isometry3d Motion() {
  Eigen::Isometry3d motion = Eigen::Isometry3d::Identity();
  motion.linear() =
      Eigen::AngleAxisd(0.02, Eigen::Vector3d(0.3, 1.0, 0.2).normalized()).toRotationMatrix();
  motion.translation() = Eigen::Vector3d(0.015, -0.006, 0.02);
  return motion;
}

double AngleDeg(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return Eigen::AngleAxisd(a.linear().transpose() * b.linear()).angle() * 180.0 / M_PI;
}

double Off(const RgbdAlignment& alignment, const Eigen::Isometry3d& truth) {
  return (alignment.reference_from_current.translation() - truth.translation()).norm();
}

// Aligned from the motion model's prediction: the true motion off by 5 mm and 0.3 degrees, as a
// constant-velocity guess is at 30 Hz.
RgbdAlignment Align(const RgbdImages& reference, const RgbdImages& current) {
  const CellCamera camera(TestCamera(), RgbdOdometryOptions().cell_px);
  Eigen::Isometry3d predicted = Motion();
  predicted.translation() += Eigen::Vector3d(0.004, -0.002, 0.002);
  predicted.linear() =
      predicted.linear() * Eigen::AngleAxisd(0.005, Eigen::Vector3d::UnitY()).toRotationMatrix();
  return AlignRgbd(camera, reference, current, predicted, RgbdOdometryOptions());
}

std::string Describe(const RgbdAlignment& alignment) {
  return "verdict " + std::to_string(static_cast<int>(alignment.verdict)) + ", rmse " +
         std::to_string(alignment.rmse_m) + " m, intensity correlation " +
         std::to_string(alignment.intensity_correlation) + ", weakest sigma " +
         std::to_string(alignment.weakest_sigma_m) + " m, paired " +
         std::to_string(alignment.paired) + " of " + std::to_string(alignment.sampled);
}

TEST(RgbdOdometryTest, RecoversTheMotionInABlankCorner) {
  const RgbdAlignment alignment =
      Align(RayCast(Corner(), Eigen::Isometry3d::Identity()), RayCast(Corner(), Motion()));
  ASSERT_TRUE(alignment.ok()) << Describe(alignment);
  EXPECT_LT(Off(alignment, Motion()), 5e-4);
  EXPECT_LT(AngleDeg(alignment.reference_from_current, Motion()), 0.03);
  EXPECT_GT(alignment.paired, alignment.sampled * 9 / 10);
}

TEST(RgbdOdometryTest, NoisyDepthStaysWithinMillimetres) {
  // Kinect-class noise at 1-2 m: a few millimetres per reading.
  const RgbdAlignment alignment = Align(RayCast(Corner(), Eigen::Isometry3d::Identity(), 0.003),
                                        RayCast(Corner(), Motion(), 0.003));
  ASSERT_TRUE(alignment.ok()) << Describe(alignment);
  EXPECT_LT(Off(alignment, Motion()), 2e-3);
  EXPECT_LT(AngleDeg(alignment.reference_from_current, Motion()), 0.1);
}

TEST(RgbdOdometryTest, TilesPinTheSlideAlongABlankWall) {
  const RgbdAlignment blank = Align(RayCast(WallOverFloor(false), Eigen::Isometry3d::Identity()),
                                    RayCast(WallOverFloor(false), Motion()));
  EXPECT_EQ(blank.verdict, RgbdAlignment::Verdict::kUnconstrained) << Describe(blank);
  const RgbdAlignment tiled = Align(RayCast(WallOverFloor(true), Eigen::Isometry3d::Identity()),
                                    RayCast(WallOverFloor(true), Motion()));
  ASSERT_TRUE(tiled.ok()) << Describe(tiled);
  EXPECT_GT(tiled.textured, 0);
  EXPECT_LT(Off(tiled, Motion()), 2e-3);
  EXPECT_LT(AngleDeg(tiled.reference_from_current, Motion()), 0.05);
}

TEST(RgbdOdometryTest, MaskedPixelsAreLeftOut) {
  // A slab in front of the corner, moving on its own: masked in both frames, it must not pull.
  RgbdImages reference = RayCast(Corner(), Eigen::Isometry3d::Identity());
  RgbdImages current = RayCast(Corner(), Motion());
  const cv::Rect slab(200, 100, 200, 300);
  reference.ignore_mask = cv::Mat::zeros(reference.depth_m.size(), CV_8U);
  current.ignore_mask = reference.ignore_mask.clone();
  reference.depth_m(slab).setTo(1.0);
  current.depth_m(slab + cv::Point(30, 0)).setTo(1.1);
  reference.ignore_mask(slab).setTo(255);
  current.ignore_mask(slab + cv::Point(30, 0)).setTo(255);
  const RgbdAlignment alignment = Align(reference, current);
  ASSERT_TRUE(alignment.ok()) << Describe(alignment);
  EXPECT_LT(Off(alignment, Motion()), 1e-3);
}

TEST(RgbdOdometryTest, ASingleBlankWallIsRefusedAsUnconstrained) {
  const std::vector<Plane> wall = {{Eigen::Vector3d::UnitZ(), 1.5}};
  const RgbdAlignment alignment =
      Align(RayCast(wall, Eigen::Isometry3d::Identity()), RayCast(wall, Motion()));
  EXPECT_EQ(alignment.verdict, RgbdAlignment::Verdict::kUnconstrained) << Describe(alignment);
}

TEST(RgbdOdometryTest, ADifferentPlaceIsRefused) {
  // The current frame sees another room: nothing pairs within the bounds.
  const std::vector<Plane> other = {{Eigen::Vector3d::UnitY(), 1.4},
                                    {Eigen::Vector3d(0.6, 0.0, 0.8), 3.5}};
  const RgbdAlignment alignment = Align(RayCast(Corner(), Eigen::Isometry3d::Identity()),
                                        RayCast(other, Eigen::Isometry3d::Identity()));
  EXPECT_FALSE(alignment.ok()) << Describe(alignment);
}

}  // namespace
}  // namespace stillmap
