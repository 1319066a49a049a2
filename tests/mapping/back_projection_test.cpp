#include "stillmap/mapping/back_projection.h"

#include <gtest/gtest.h>

#include <opencv2/calib3d.hpp>

#include "stillmap/io/error.h"
#include "test_util.h"

namespace stillmap {
namespace {

TEST(BackProjectionTest, UndistortedCameraFollowsEquation12) {
  const Camera camera = testing::SmallCamera();
  const DepthBackProjector projector(camera, {});
  cv::Mat depth(camera.height, camera.width, CV_32FC1, cv::Scalar(0.0f));
  cv::Mat color(camera.height, camera.width, CV_8UC3, cv::Scalar(1, 2, 3));
  depth.at<float>(7, 50) = 1.5f;
  ColoredPoints points;
  projector.BackProject(depth, color, cv::Mat(), Eigen::Isometry3f::Identity(), &points);
  ASSERT_EQ(points.size(), 1u);
  // P = (z (u - cx) / fx, z (v - cy) / fy, z), paper 000 eq. (12).
  EXPECT_NEAR(points.positions[0].x(), 1.5 * (50 - camera.cx) / camera.fx, 1e-6);
  EXPECT_NEAR(points.positions[0].y(), 1.5 * (7 - camera.cy) / camera.fy, 1e-6);
  EXPECT_FLOAT_EQ(points.positions[0].z(), 1.5f);
  EXPECT_EQ(points.colors[0], (std::array<std::uint8_t, 3>{3, 2, 1}));  // BGR in, RGB out
}

TEST(BackProjectionTest, DistortedRaysProjectBackOntoTheirPixel) {
  Camera camera = CameraPreset("tum1");  // strong radial distortion
  const DepthBackProjector projector(camera, {});
  const cv::Matx33d k(camera.fx, 0, camera.cx, 0, camera.fy, camera.cy, 0, 0, 1);
  const std::vector<double> distortion(camera.distortion.begin(), camera.distortion.end());
  for (const cv::Point pixel : {cv::Point(0, 0), cv::Point(639, 479), cv::Point(320, 240),
                                cv::Point(100, 400), cv::Point(600, 30)}) {
    const Eigen::Vector2f ray = projector.Ray(pixel.x, pixel.y);
    std::vector<cv::Point3d> point = {cv::Point3d(2.0 * ray.x(), 2.0 * ray.y(), 2.0)};
    std::vector<cv::Point2d> projected;
    cv::projectPoints(point, cv::Vec3d::all(0), cv::Vec3d::all(0), k, distortion, projected);
    EXPECT_NEAR(projected[0].x, pixel.x, 0.01) << pixel;
    EXPECT_NEAR(projected[0].y, pixel.y, 0.01) << pixel;
  }
}

TEST(BackProjectionTest, RangeMaskAndPoseAreApplied) {
  const Camera camera = testing::SmallCamera();
  BackProjectionOptions options;
  options.min_depth = 0.5;
  options.max_depth = 3.0;
  const DepthBackProjector projector(camera, options);
  cv::Mat depth(camera.height, camera.width, CV_32FC1, cv::Scalar(2.0f));
  depth.at<float>(0, 0) = 0.2f;  // too near
  depth.at<float>(0, 1) = 3.5f;  // too far
  depth.at<float>(0, 2) = 0.0f;  // no reading
  cv::Mat mask(camera.height, camera.width, CV_8UC1, cv::Scalar(0));
  mask.rowRange(10, 20).setTo(255);
  cv::Mat color(camera.height, camera.width, CV_8UC3, cv::Scalar(0, 0, 0));
  Eigen::Isometry3f world_from_camera = Eigen::Isometry3f::Identity();
  world_from_camera.translation() = Eigen::Vector3f(1, 2, 3);
  ColoredPoints points;
  projector.BackProject(depth, color, mask, world_from_camera, &points);
  EXPECT_EQ(points.size(), static_cast<size_t>(camera.width * (camera.height - 10) - 3));
  for (const Eigen::Vector3f& p : points.positions) EXPECT_FLOAT_EQ(p.z(), 5.0f);
}

TEST(BackProjectionTest, ImpossibleOptionsAreRejected) {
  BackProjectionOptions options;
  options.max_depth = 0.05;
  EXPECT_THROW(options.Validate(), InputError);
  options = {};
  options.pixel_stride = 0;
  EXPECT_THROW(options.Validate(), InputError);
}

}  // namespace
}  // namespace stillmap
