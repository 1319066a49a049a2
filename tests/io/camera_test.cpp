#include "stillmap/io/camera.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <limits>
#include <opencv2/calib3d.hpp>
#include <vector>

#include "stillmap/io/error.h"
#include "test_util.h"

namespace stillmap {
namespace {

using testing::TempDir;
using testing::WriteText;

constexpr const char kCameraYaml[] =
    "width: 640\nheight: 480\nfx: 542.8\nfy: 542.5\ncx: 315.5\ncy: 237.7\n"
    "distortion: [0.04, -0.1, -0.0007, -0.0001, 0.0]\ndepth_factor: 5000.0\n";

TEST(CameraTest, PresetsMatchPublishedCalibrations) {
  const Camera tum3 = CameraPreset("tum3");
  EXPECT_DOUBLE_EQ(tum3.fx, 535.4);
  EXPECT_DOUBLE_EQ(tum3.cy, 247.6);
  EXPECT_FALSE(tum3.HasDistortion());
  const Camera tum1 = CameraPreset("tum1");
  EXPECT_TRUE(tum1.HasDistortion());
  EXPECT_DOUBLE_EQ(tum1.distortion[4], 1.1633);
  EXPECT_DOUBLE_EQ(CameraPreset("ros_default").cx, 319.5);
  for (const std::string& name : CameraPresetNames()) EXPECT_NO_THROW(CameraPreset(name));
  EXPECT_THROW(CameraPreset("kinect9"), InputError);
}

TEST(CameraTest, ReadsYamlWithBodyFromCamera) {
  TempDir dir;
  WriteText(dir / "camera.yaml", std::string(kCameraYaml) +
                                     "groundtruth_body_from_camera: [0, -1, 0, 0.1, 1, 0, 0, 0.2, "
                                     "0, 0, 1, 0.3, 0, 0, 0, 1]\n");
  const Camera camera = LoadCameraYaml(dir / "camera.yaml");
  EXPECT_EQ(camera.width, 640);
  EXPECT_DOUBLE_EQ(camera.fx, 542.8);
  EXPECT_DOUBLE_EQ(camera.distortion[0], 0.04);
  ASSERT_TRUE(camera.groundtruth_body_from_camera.has_value());
  EXPECT_DOUBLE_EQ(camera.groundtruth_body_from_camera->matrix()(0, 1), -1.0);
  EXPECT_DOUBLE_EQ(camera.groundtruth_body_from_camera->translation().z(), 0.3);
}

TEST(CameraTest, MissingKeyIsNamed) {
  TempDir dir;
  std::string text = kCameraYaml;
  text.erase(text.find("fy:"), text.find("cx:") - text.find("fy:"));
  WriteText(dir / "camera.yaml", text);
  try {
    LoadCameraYaml(dir / "camera.yaml");
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("missing key 'fy'"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("camera.yaml"), std::string::npos);
  }
}

TEST(CameraTest, RejectsUnknownKeysAndImpossibleValues) {
  TempDir dir;
  WriteText(dir / "a.yaml", std::string(kCameraYaml) + "fz: 3\n");
  EXPECT_THROW(LoadCameraYaml(dir / "a.yaml"), InputError);
  std::string negative = kCameraYaml;
  negative.replace(negative.find("fx: 542.8"), 9, "fx: -5");
  WriteText(dir / "b.yaml", negative);
  EXPECT_THROW(LoadCameraYaml(dir / "b.yaml"), InputError);
  WriteText(dir / "c.yaml",
            std::string(kCameraYaml) +
                "groundtruth_body_from_camera: [2, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, "
                "0, 0, 0, 1]\n");
  EXPECT_THROW(LoadCameraYaml(dir / "c.yaml"), InputError);
  WriteText(dir / "d.yaml", "width: [\n");
  EXPECT_THROW(LoadCameraYaml(dir / "d.yaml"), InputError);
  EXPECT_THROW(LoadCameraYaml(dir / "missing.yaml"), InputError);
}

// Pixel rays and projection are inverse to each other: every pixel's undistorted ray projects
// back onto the pixel (within OpenCV's iterative undistortion, 0.1 px at Bonn's corners), with
// and without distortion; the noise model is Nguyen's at a few depths.
TEST(CameraTest, PixelRaysProjectBackOntoTheirPixels) {
  for (const char* name : {"bonn", "tum3"}) {
    const Camera camera = CameraPreset(name);
    const std::vector<Eigen::Vector2f> rays = PixelRays(camera);
    ASSERT_EQ(rays.size(), static_cast<size_t>(camera.width) * static_cast<size_t>(camera.height));
    const PixelProjection project(camera);
    float worst = 0.0f;
    for (int v = 0; v < camera.height; v += 7) {
      for (int u = 0; u < camera.width; u += 7) {
        const Eigen::Vector2f& ray =
            rays[static_cast<size_t>(v) * static_cast<size_t>(camera.width) +
                 static_cast<size_t>(u)];
        const Eigen::Vector2f pixel = project(ray.x(), ray.y());
        worst = std::max(worst, (pixel - Eigen::Vector2f(u, v)).norm());
      }
    }
    EXPECT_LT(worst, camera.HasDistortion() ? 0.2f : 1e-3f) << name;
  }
  EXPECT_NEAR(KinectDepthSigma(0.4f), 0.0012f, 1e-7f);
  EXPECT_NEAR(KinectDepthSigma(3.0f), 0.0012f + 0.0019f * 2.6f * 2.6f, 1e-6f);
}

// OpenCV's rational model (ROS rational_polynomial, as an Azure Kinect's CameraInfo gives it):
// PixelProjection agrees with cv::projectPoints given all eight coefficients, and each pixel's
// ray projects back onto it; plumb_bob cameras keep OpenCV's five.
TEST(CameraTest, RationalDistortionProjectsAsOpenCvDoes) {
  Camera camera;
  camera.width = 640;
  camera.height = 576;
  camera.fx = 504.0;
  camera.fy = 504.2;
  camera.cx = 321.1;
  camera.cy = 333.6;
  camera.distortion = {0.45, -2.6, 0.0004, -0.0002, 1.5};
  camera.rational = {0.33, -2.45, 1.43};
  camera.depth_factor = 1000.0;
  ASSERT_NO_THROW(camera.Validate("azure"));
  ASSERT_EQ(camera.Coefficients().size(), 8u);
  EXPECT_EQ(CameraPreset("bonn").Coefficients().size(), 5u);
  const PixelProjection project(camera);
  std::vector<cv::Point3d> points;
  for (double x = -0.6; x <= 0.6; x += 0.05) {
    for (double y = -0.5; y <= 0.5; y += 0.05) points.emplace_back(x, y, 1.0);
  }
  std::vector<cv::Point2d> expected;
  const cv::Matx33d k(camera.fx, 0, camera.cx, 0, camera.fy, camera.cy, 0, 0, 1);
  cv::projectPoints(points, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), k, camera.Coefficients(),
                    expected);
  for (size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector2f pixel =
        project(static_cast<float>(points[i].x), static_cast<float>(points[i].y));
    EXPECT_NEAR(pixel.x(), expected[i].x, 0.01);
    EXPECT_NEAR(pixel.y(), expected[i].y, 0.01);
  }
  const std::vector<Eigen::Vector2f> rays = PixelRays(camera);
  float worst = 0.0f;
  for (int v = 0; v < camera.height; v += 9) {
    for (int u = 0; u < camera.width; u += 9) {
      const Eigen::Vector2f& ray = rays[static_cast<size_t>(v) * 640 + static_cast<size_t>(u)];
      worst = std::max(worst, (project(ray.x(), ray.y()) - Eigen::Vector2f(u, v)).norm());
    }
  }
  EXPECT_LT(worst, 0.2f);
}

// Every preset passes; cameras that would ruin a run silently are refused by name: non-finite or
// absurd focal lengths, a principal point outside the image, distortion that folds pixels over
// or cannot be inverted.
TEST(CameraTest, ImplausibleCamerasAreRefused) {
  for (const std::string& name : CameraPresetNames()) {
    EXPECT_NO_THROW(CameraPreset(name).Validate(name)) << name;
  }
  auto refused = [](Camera camera, const std::string& expected) {
    try {
      camera.Validate("test");
    } catch (const InputError& e) {
      return std::string(e.what()).find(expected) != std::string::npos;
    }
    return false;
  };
  const Camera good = CameraPreset("bonn");
  Camera camera = good;
  camera.fx = std::numeric_limits<double>::infinity();
  EXPECT_TRUE(refused(camera, "fx and fy"));
  camera.fx = camera.fy = 1e300;
  EXPECT_TRUE(refused(camera, "field of view"));
  camera = good;
  camera.cx = 1e10;
  EXPECT_TRUE(refused(camera, "principal point"));
  camera = good;
  camera.distortion = {1e10, -1e10, 0, 0, 1e10};
  EXPECT_TRUE(refused(camera, "distortion"));
  camera.distortion = {-0.9, 0, 0, 0, 0};  // the radial term turns back inside the image
  EXPECT_TRUE(refused(camera, "fold over"));
  camera = good;
  camera.depth_factor = std::numeric_limits<double>::infinity();
  EXPECT_TRUE(refused(camera, "depth_factor"));
  camera = good;
  camera.width = 100000;
  EXPECT_TRUE(refused(camera, "width and height"));
}
}  // namespace
}  // namespace stillmap
