// Depth in a camera of its own registered into colour (bag depth without aligned_depth_to_color):
// /tf_static's chain between two optical frames composed as tf does; a tilted plane seen by a
// 320x240 depth camera lands in a 640x480 colour camera with lens distortion at the depth the
// plane has along each colour pixel's ray (the ray from OpenCV's undistortPoints, independent of
// the registration's forward projection); a TFMessage as ROS 2 writes it decodes.
#include "bag/depth_registration.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <opencv2/calib3d.hpp>

#include "bag_test_util.h"

namespace stillmap {
namespace {

RosTransform Transform(const std::string& parent, const std::string& child,
                       const Eigen::Isometry3d& pose) {
  RosTransform transform;
  transform.parent = parent;
  transform.child = child;
  const Eigen::Quaterniond q(pose.linear());
  transform.rotation = {q.x(), q.y(), q.z(), q.w()};
  transform.translation = {pose.translation().x(), pose.translation().y(), pose.translation().z()};
  return transform;
}

Eigen::Isometry3d Pose(double tx, double ty, double tz, double angle, Eigen::Vector3d axis) {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = Eigen::AngleAxisd(angle, axis.normalized()).toRotationMatrix();
  pose.translation() = Eigen::Vector3d(tx, ty, tz);
  return pose;
}

TEST(DepthRegistrationTest, StaticTransformsChainAsTfDoes) {
  // realsense2_camera's tree: camera_link -> {depth, color}_frame -> *_optical_frame.
  const Eigen::Isometry3d optical = Pose(0, 0, 0, M_PI / 2, {-1, 1, -1});  // x right, z ahead
  const Eigen::Isometry3d link_depth = Pose(0, 0, 0, 0, {0, 0, 1});
  const Eigen::Isometry3d link_color = Pose(0.0, 0.015, 0.0001, 0.004, {0.2, 1, 0.1});
  const std::vector<RosTransform> tf = {
      Transform("camera_link", "camera_depth_frame", link_depth),
      Transform("camera_depth_frame", "camera_depth_optical_frame", optical),
      Transform("camera_link", "camera_color_frame", link_color),
      Transform("camera_color_frame", "camera_color_optical_frame", optical),
      Transform("map", "odom", Pose(5, 0, 0, 1.0, {0, 0, 1}))};
  const std::optional<Eigen::Isometry3d> found =
      FindStaticTransform(tf, "camera_color_optical_frame", "camera_depth_optical_frame");
  ASSERT_TRUE(found.has_value());
  const Eigen::Isometry3d expected = (link_color * optical).inverse() * (link_depth * optical);
  EXPECT_TRUE(found->isApprox(expected, 1e-12)) << found->matrix() << "\n" << expected.matrix();
  EXPECT_FALSE(FindStaticTransform(tf, "camera_color_optical_frame", "odom").has_value());
  EXPECT_FALSE(FindStaticTransform(tf, "camera_color_optical_frame", "nowhere").has_value());
}

RosCameraInfo Info(std::uint32_t width, std::uint32_t height, double f, std::vector<double> d,
                   const std::string& frame) {
  RosCameraInfo info;
  info.width = width;
  info.height = height;
  info.k = {f, 0, (width - 1) / 2.0, 0, f, (height - 1) / 2.0, 0, 0, 1};
  info.distortion_model = "plumb_bob";
  info.d = std::move(d);
  info.header.frame_id = frame;
  return info;
}

// Depth along a unit-z ray (x, y, 1) to the plane n . X = d.
double DepthOnPlane(const Eigen::Vector3d& n, double d, double x, double y) {
  return d / n.dot(Eigen::Vector3d(x, y, 1.0));
}

TEST(DepthRegistrationTest, ATiltedPlaneLandsAtItsDepthInTheColourCamera) {
  const RosCameraInfo depth_info = Info(320, 240, 285.0, {}, "depth");
  const RosCameraInfo color_info = Info(640, 480, 535.0, {-0.1, 0.02, 0.0005, -0.0004, 0}, "rgb");
  const Eigen::Isometry3d color_from_depth = Pose(-0.025, 0.002, 0.001, 0.02, {0.3, 1, 0});
  // The plane in the colour frame, and the same plane in the depth frame.
  const Eigen::Vector3d n_color = Eigen::Vector3d(0.4, -0.1, 1.0).normalized();
  const double d_color = 2.0;
  const Eigen::Vector3d n_depth = color_from_depth.linear().transpose() * n_color;
  const double d_depth = d_color - n_color.dot(color_from_depth.translation());
  cv::Mat depth(240, 320, CV_32FC1);
  for (int v = 0; v < depth.rows; ++v) {
    for (int u = 0; u < depth.cols; ++u) {
      depth.at<float>(v, u) = static_cast<float>(
          DepthOnPlane(n_depth, d_depth, (u - 159.5) / 285.0, (v - 119.5) / 285.0));
    }
  }
  const DepthRegistration registration(depth_info, color_info, color_from_depth, "test");
  const cv::Mat registered = registration.Register(depth, "test");
  ASSERT_EQ(registered.size(), cv::Size(640, 480));
  // Each colour pixel's ray through OpenCV's undistortion of the colour camera.
  std::vector<cv::Point2f> pixels, rays;
  for (int v = 60; v < 420; ++v) {
    for (int u = 80; u < 560; ++u)
      pixels.emplace_back(static_cast<float>(u), static_cast<float>(v));
  }
  cv::undistortPoints(pixels, rays, cv::Matx33d(color_info.k.data()), color_info.d);
  std::vector<double> errors;
  for (size_t i = 0; i < pixels.size(); ++i) {
    const float z = registered.at<float>(cvRound(pixels[i].y), cvRound(pixels[i].x));
    if (z == 0.0f) continue;
    errors.push_back(std::abs(z - DepthOnPlane(n_color, d_color, rays[i].x, rays[i].y)));
  }
  EXPECT_GT(static_cast<double>(errors.size()) / static_cast<double>(pixels.size()), 0.99);
  std::sort(errors.begin(), errors.end());
  // [m]: a footprint (about 2 colour pixels) takes its corners' mean depth, so pixels off its
  // middle are off by the plane's slope times their offset.
  EXPECT_LT(errors[errors.size() / 2], 0.0015);
  EXPECT_LT(errors[errors.size() * 99 / 100], 0.003);
  EXPECT_THROW(registration.Register(cv::Mat(10, 10, CV_32FC1, cv::Scalar(1.0f)), "test"),
               std::exception);
}

TEST(DepthRegistrationTest, ATfMessageFromRosTwoDecodes) {
  Cdr cdr;
  cdr.U32(1);           // one transform
  cdr.U32(1700000000);  // header stamp
  cdr.U32(5);
  cdr.String("camera_link");
  cdr.String("camera_depth_frame");
  for (const double value : {0.01, -0.02, 0.03, 0.0, 0.0, 0.0, 1.0}) cdr.F64(value);
  std::vector<RosTransform> transforms;
  std::string error;
  ASSERT_TRUE(DecodeRosTfMessage(cdr.bytes().data(), cdr.bytes().size(), BagSerialization::kCdr,
                                 &transforms, &error))
      << error;
  ASSERT_EQ(transforms.size(), 1u);
  EXPECT_EQ(transforms[0].parent, "camera_link");
  EXPECT_EQ(transforms[0].child, "camera_depth_frame");
  EXPECT_EQ(transforms[0].translation, (std::array<double, 3>{0.01, -0.02, 0.03}));
  EXPECT_EQ(transforms[0].rotation, (std::array<double, 4>{0, 0, 0, 1}));
  for (size_t cut = 0; cut + 1 < cdr.bytes().size(); cut += 7) {
    std::vector<RosTransform> partial;
    EXPECT_FALSE(
        DecodeRosTfMessage(cdr.bytes().data(), cut, BagSerialization::kCdr, &partial, &error));
  }
}

}  // namespace
}  // namespace stillmap
