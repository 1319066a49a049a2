#include "stillmap/mapping/back_projection.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
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

TEST(BackProjectionTest, WithoutColourTheSamePositionsComeAlone) {
  const Camera camera = testing::SmallCamera();
  const DepthBackProjector projector(camera, {});
  cv::Mat depth(camera.height, camera.width, CV_32FC1, cv::Scalar(0.0f));
  depth(cv::Rect(10, 5, 30, 20)).setTo(1.25f);
  depth.at<float>(15, 20) = 0.0f;
  cv::Mat mask(camera.height, camera.width, CV_8UC1, cv::Scalar(0));
  mask(cv::Rect(10, 5, 4, 4)).setTo(255);
  const cv::Mat color(camera.height, camera.width, CV_8UC3, cv::Scalar(9, 8, 7));
  Eigen::Isometry3f world_from_camera(Eigen::AngleAxisf(0.3f, Eigen::Vector3f::UnitY()));
  world_from_camera.translation() = Eigen::Vector3f(0.5f, -1, 2);
  ColoredPoints coloured, alone;
  projector.BackProject(depth, color, mask, world_from_camera, &coloured);
  projector.BackProject(depth, cv::Mat(), mask, world_from_camera, &alone);
  ASSERT_EQ(coloured.size(), static_cast<size_t>(30 * 20 - 16 - 1));
  EXPECT_EQ(alone.positions, coloured.positions);
  EXPECT_TRUE(alone.colors.empty());
}

// A plane seen by a camera: 1/z = a + b u + c v.
cv::Mat PlaneDepth(int width, int height, double noise_sigma, std::uint64_t seed) {
  cv::Mat depth(height, width, CV_32FC1);
  cv::RNG rng(seed);
  for (int v = 0; v < height; ++v) {
    for (int u = 0; u < width; ++u) {
      depth.at<float>(v, u) = static_cast<float>(
          1.0 / (0.45 + 0.0004 * (u - width / 2.0) - 0.0003 * (v - height / 2.0)) +
          rng.gaussian(noise_sigma));
    }
  }
  return depth;
}

TEST(BackProjectionTest, SmoothingIsExactOnPlanesAndReducesNoise) {
  const cv::Mat exact = PlaneDepth(640, 480, 0.0, 1);
  cv::Mat smoothed;
  SmoothDepth(exact, 2, &smoothed);
  double worst = 0.0;
  cv::minMaxLoc(cv::abs(smoothed - exact), nullptr, &worst);
  EXPECT_LT(worst, 1e-4);  // float rounding only
  // Noise of 5 mm at about 2.2 m (sigma(2.2 m) = 7.4 mm, so no reading leaves the band): a 5x5
  // mean divides the standard deviation by about 5.
  const cv::Mat noisy = PlaneDepth(640, 480, 0.005, 2);
  SmoothDepth(noisy, 2, &smoothed);
  cv::Scalar mean, before, after;
  cv::meanStdDev(noisy - exact, mean, before);
  cv::meanStdDev(smoothed - exact, mean, after);
  EXPECT_NEAR(before[0], 0.005, 2e-4);
  EXPECT_LT(after[0], before[0] / 3.5);
  // A block 0.5 m in front of the plane (a person's edge) is neither smoothed away nor mixed
  // with the plane. Beside it the window is one-sided and the known bias appears: about the depth
  // gradient per pixel, here z^2 * 0.0004 = 2 mm.
  cv::Mat step = exact.clone();
  step(cv::Rect(300, 200, 40, 40)) -= 0.5f;
  SmoothDepth(step, 2, &smoothed);
  EXPECT_NEAR(smoothed.at<float>(220, 320), step.at<float>(220, 320), 1e-3);
  EXPECT_NEAR(smoothed.at<float>(220, 299), exact.at<float>(220, 299), 3e-3);
}

// SmoothDepth's definition, one pixel at a time: the mean inverse depth of the readings in the
// window (shrunk symmetrically at the border) within 3 sigma of the centre's, inverted.
float SmoothedByDefinition(const cv::Mat& depth, int radius, int v, int u) {
  const float z = depth.at<float>(v, u);
  if (z <= 0.0f) return 0.0f;
  const int rv = std::min({radius, v, depth.rows - 1 - v});
  const int ru = std::min({radius, u, depth.cols - 1 - u});
  const float inverse_z = 1.0f / z;
  const float limit = 3.0f * KinectDepthSigma(z) * inverse_z * inverse_z;
  float sum = 0.0f, count = 0.0f;
  for (int y = v - rv; y <= v + rv; ++y) {
    for (int x = u - ru; x <= u + ru; ++x) {
      const float n = depth.at<float>(y, x);
      if (n > 0.0f && std::abs(1.0f / n - inverse_z) < limit) {
        sum += 1.0f / n;
        count += 1.0f;
      }
    }
  }
  return count / sum;
}

TEST(BackProjectionTest, SmoothingIsItsDefinitionToTheBitAtEveryRadiusAndSize) {
  // Readings 1-3 m with 3 mm noise, a fifth of them missing (0) and a few NaN.
  cv::RNG rng(7);
  for (const cv::Size size : {cv::Size(64, 48), cv::Size(5, 9), cv::Size(3, 2), cv::Size(1, 7)}) {
    cv::Mat depth(size, CV_32FC1);
    for (int v = 0; v < size.height; ++v) {
      for (int u = 0; u < size.width; ++u) {
        const double draw = rng.uniform(0.0, 1.0);
        depth.at<float>(v, u) =
            draw < 0.2    ? 0.0f
            : draw < 0.22 ? std::numeric_limits<float>::quiet_NaN()
                          : static_cast<float>(1.0 + 0.02 * u + 0.01 * v + rng.gaussian(0.003));
      }
    }
    for (int radius = 0; radius <= 5; ++radius) {
      cv::Mat smoothed;
      SmoothDepth(depth, radius, &smoothed);
      for (int v = 0; v < size.height; ++v) {
        for (int u = 0; u < size.width; ++u) {
          const float expected = SmoothedByDefinition(depth, radius, v, u);
          const float got = smoothed.at<float>(v, u);
          ASSERT_TRUE(got == expected ||  // exactly, not within a tolerance
                      (std::isnan(expected) && std::isnan(got)))
              << size << " radius " << radius << " at (" << u << ", " << v << "): " << got
              << " against " << expected;
        }
      }
    }
  }
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
