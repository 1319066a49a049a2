// The RealSense recorder's layout (issue 49): its topics told apart, librealsense's distortion
// models restated as plumb_bob (checked by OpenCV's own projection against librealsense's
// formulas), the extrinsics composed into depth-in-colour, its options decoded, YUYV colour.
#include "bag/realsense_layout.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "bag/bag_streams.h"

namespace stillmap {
namespace {

TEST(RealSenseLayoutTest, TopicsAreToldApartByTheirPlaceInTheLayout) {
  EXPECT_EQ(ClassifyRealSenseTopic("/device_0/info"), RealSenseTopic::kDeviceInfo);
  EXPECT_EQ(ClassifyRealSenseTopic("/device_0/sensor_1/info"), RealSenseTopic::kSensorInfo);
  EXPECT_EQ(ClassifyRealSenseTopic("/device_0/sensor_1/Color_0/tf/0"), RealSenseTopic::kExtrinsic);
  EXPECT_EQ(ClassifyRealSenseTopic("/device_0/sensor_0/option/Depth Units/value"),
            RealSenseTopic::kDepthUnits);
  EXPECT_EQ(ClassifyRealSenseTopic("/device_0/sensor_0/option/Exposure/value"),
            RealSenseTopic::kNone);
  EXPECT_EQ(ClassifyRealSenseTopic("/device_x/info"), RealSenseTopic::kNone);
  EXPECT_EQ(ClassifyRealSenseTopic("/camera/color/camera_info"), RealSenseTopic::kNone);
  EXPECT_EQ(RealSenseStreamOf("/device_0/sensor_0/Depth_0/image/data"),
            "/device_0/sensor_0/Depth_0");
  EXPECT_EQ(RealSenseStreamOf("/device_0/sensor_0/Depth_0/image/metadata"), "");
  EXPECT_EQ(RealSenseStreamOf("/camera/depth/image_raw"), "");
  EXPECT_EQ(RealSenseSensorOf("/device_0/sensor_0/Depth_0"), "/device_0/sensor_0");
  EXPECT_EQ(CameraInfoTopicOf("/device_0/sensor_1/Color_0/image/data"),
            "/device_0/sensor_1/Color_0/info/camera_info");
  EXPECT_EQ(CameraInfoTopicOf("/camera/color/image_raw"), "/camera/color/camera_info");
}

RosCameraInfo Info(const std::string& model, std::vector<double> d) {
  RosCameraInfo info;
  info.width = 640;
  info.height = 480;
  info.k = {615.0, 0.0, 321.0, 0.0, 614.0, 243.0, 0.0, 0.0, 1.0};
  info.distortion_model = model;
  info.d = std::move(d);
  return info;
}

// librealsense's Brown-Conrady polynomial as its rsutil.h writes it, on normalized coordinates.
cv::Point2d Polynomial(const std::vector<double>& c, cv::Point2d p, bool modified) {
  const double r2 = p.x * p.x + p.y * p.y;
  const double f = 1 + c[0] * r2 + c[1] * r2 * r2 + c[4] * r2 * r2 * r2;
  const cv::Point2d q = modified ? p * f : p;
  return {p.x * f + 2 * c[2] * q.x * q.y + c[3] * (r2 + 2 * q.x * q.x),
          p.y * f + 2 * c[3] * q.x * q.y + c[2] * (r2 + 2 * q.y * q.y)};
}

// The largest distance [px] between OpenCV's projection of `undistorted` (normalized) with the
// restated camera and the pixels `expected`.
double WorstProjection(const RosCameraInfo& info, const std::vector<cv::Point2d>& undistorted,
                       const std::vector<cv::Point2d>& expected) {
  std::vector<cv::Point3d> points;
  points.reserve(undistorted.size());
  for (const cv::Point2d& p : undistorted) points.emplace_back(p.x, p.y, 1.0);
  std::vector<cv::Point2d> projected;
  cv::projectPoints(points, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), cv::Matx33d(info.k.data()),
                    info.d, projected);
  double worst = 0.0;
  for (size_t i = 0; i < projected.size(); ++i) {
    worst = std::max(worst, cv::norm(projected[i] - expected[i]));
  }
  return worst;
}

TEST(RealSenseLayoutTest, BrownConradyIsPlumbBobAndZeroCoefficientsAreNoDistortion) {
  RosCameraInfo brown = Info("Brown Conrady", {0.1, -0.2, 0.001, 0.002, 0.05});
  double fit = -1.0;
  ASSERT_TRUE(RestateRealSenseModel(&brown, &fit));
  EXPECT_EQ(brown.distortion_model, "plumb_bob");
  EXPECT_EQ(brown.d, (std::vector<double>{0.1, -0.2, 0.001, 0.002, 0.05}));
  EXPECT_EQ(fit, 0.0);
  RosCameraInfo inverse_zero = Info("Inverse Brown Conrady", {0, 0, 0, 0, 0});
  ASSERT_TRUE(RestateRealSenseModel(&inverse_zero, &fit));
  EXPECT_EQ(inverse_zero.distortion_model, "plumb_bob");
  EXPECT_EQ(inverse_zero.d, std::vector<double>(5, 0.0));
}

TEST(RealSenseLayoutTest, TheInverseAndModifiedFormsAreFittedWithinATenthOfAPixel) {
  const std::vector<double> c = {0.12, -0.25, 0.0008, -0.0011, 0.09};
  for (const bool inverse : {true, false}) {
    RosCameraInfo info = Info(inverse ? "Inverse Brown Conrady" : "Modified Brown Conrady", c);
    double fit = -1.0;
    ASSERT_TRUE(RestateRealSenseModel(&info, &fit));
    EXPECT_EQ(info.distortion_model, "plumb_bob");
    std::vector<cv::Point2d> undistorted, expected;
    for (int v = 5; v < 480; v += 37) {
      for (int u = 3; u < 640; u += 41) {
        const cv::Point2d pixel(u, v), normalized((u - 321.0) / 615.0, (v - 243.0) / 614.0);
        if (inverse) {  // the polynomial takes the recorded (distorted) pixel to its ray
          undistorted.push_back(Polynomial(c, normalized, false));
          expected.push_back(pixel);
        } else {  // the polynomial takes a ray to the pixel it is recorded at
          undistorted.push_back(normalized);
          const cv::Point2d d = Polynomial(c, normalized, true);
          expected.emplace_back(615.0 * d.x + 321.0, 614.0 * d.y + 243.0);
        }
      }
    }
    const double worst = WorstProjection(info, undistorted, expected);
    EXPECT_LT(worst, 0.1) << (inverse ? "inverse" : "modified");
    EXPECT_LE(worst, fit + 1e-6) << "the fit's own figure, over the whole image, understates";
  }
}

TEST(RealSenseLayoutTest, FisheyeModelsAndUnknownNamesAreLeftAlone) {
  double fit = 0.0;
  RosCameraInfo fisheye = Info("Kannala Brandt4", {0.1, 0.2, 0.3, 0.4, 0.0});
  EXPECT_FALSE(RestateRealSenseModel(&fisheye, &fit));
  EXPECT_EQ(fisheye.distortion_model, "Kannala Brandt4");
  RosCameraInfo plumb = Info("plumb_bob", {0.1, 0, 0, 0, 0});
  EXPECT_FALSE(RestateRealSenseModel(&plumb, &fit));
}

RosTransform Transform(const Eigen::Isometry3d& pose) {
  RosTransform transform;
  const Eigen::Quaterniond q(pose.linear());
  transform.rotation = {q.x(), q.y(), q.z(), q.w()};
  transform.translation = {pose.translation().x(), pose.translation().y(), pose.translation().z()};
  return transform;
}

TEST(RealSenseLayoutTest, DepthInColourComesThroughTheGroupsReference) {
  // librealsense stores reference -> stream: a point p of the reference is R p + t in the stream.
  Eigen::Isometry3d depth_from_reference = Eigen::Isometry3d::Identity();
  depth_from_reference.rotate(Eigen::AngleAxisd(0.02, Eigen::Vector3d::UnitZ()));
  depth_from_reference.pretranslate(Eigen::Vector3d(0.003, 0.0, 0.0));
  Eigen::Isometry3d color_from_reference = Eigen::Isometry3d::Identity();
  color_from_reference.rotate(Eigen::AngleAxisd(-0.01, Eigen::Vector3d::UnitY()));
  color_from_reference.pretranslate(Eigen::Vector3d(0.015, 0.001, -0.002));
  RealSenseDetails details;
  details.stream_from_reference["/device_0/sensor_0/Depth_0"]["0"] =
      Transform(depth_from_reference);
  details.stream_from_reference["/device_0/sensor_1/Color_0"]["0"] =
      Transform(color_from_reference);
  const std::optional<Eigen::Isometry3d> color_from_depth =
      RealSenseColorFromDepth(details, "/device_0/sensor_1/Color_0", "/device_0/sensor_0/Depth_0");
  ASSERT_TRUE(color_from_depth.has_value());
  const Eigen::Vector3d in_reference(0.4, -0.3, 2.0);
  const Eigen::Vector3d seen_by_depth = depth_from_reference * in_reference;
  EXPECT_LT(((*color_from_depth) * seen_by_depth - color_from_reference * in_reference).norm(),
            1e-9);
  details.stream_from_reference["/device_0/sensor_1/Color_0"].clear();
  details.stream_from_reference["/device_0/sensor_1/Color_0"]["1"] =
      Transform(color_from_reference);
  EXPECT_FALSE(
      RealSenseColorFromDepth(details, "/device_0/sensor_1/Color_0", "/device_0/sensor_0/Depth_0")
          .has_value())
      << "no group in common";
}

TEST(RealSenseLayoutTest, OptionsAndDeviceInfoAreDecodedFromTheirMessages) {
  RealSenseDetails details;
  const float units = 0.0001f;
  std::uint8_t bytes[4];
  std::memcpy(bytes, &units, 4);  // std_msgs/Float32 in ROS 1: four little-endian bytes
  AddRealSenseDetail(RealSenseTopic::kDepthUnits, "/device_0/sensor_0/option/Depth Units/value",
                     bytes, 4, BagSerialization::kRos1, &details);
  EXPECT_DOUBLE_EQ(details.depth_units.at("/device_0/sensor_0"), 0.0001);
  const std::string key = "Name", value = "Intel RealSense D455";
  std::vector<std::uint8_t> pair;
  for (const std::string* text : {&key, &value}) {
    const std::uint32_t length = static_cast<std::uint32_t>(text->size());
    pair.insert(pair.end(), reinterpret_cast<const std::uint8_t*>(&length),
                reinterpret_cast<const std::uint8_t*>(&length) + 4);
    pair.insert(pair.end(), text->begin(), text->end());
  }
  AddRealSenseDetail(RealSenseTopic::kDeviceInfo, "/device_0/info", pair.data(), pair.size(),
                     BagSerialization::kRos1, &details);
  EXPECT_EQ(DescribeRealSenseDevice(details), "Intel RealSense D455");
  AddRealSenseDetail(RealSenseTopic::kExtrinsic, "/device_0/sensor_0/Depth_0/tf/0", bytes, 4,
                     BagSerialization::kRos1, &details);
  EXPECT_EQ(details.undecoded, 1u) << "four bytes are no geometry_msgs/Transform";
}

TEST(RealSenseLayoutTest, YuyvColourDecodesToTheColoursItWasMadeFrom) {
  // Pixels equal in pairs, so 4:2:2's shared chroma loses nothing but rounding.
  cv::Mat bgr(4, 8, CV_8UC3);
  for (int v = 0; v < bgr.rows; ++v) {
    for (int u = 0; u < bgr.cols; ++u) {
      const int pair = u / 2;
      bgr.at<cv::Vec3b>(v, u) = cv::Vec3b(static_cast<std::uint8_t>(40 + 50 * pair),
                                          static_cast<std::uint8_t>(200 - 30 * v),
                                          static_cast<std::uint8_t>(90 + 20 * pair + 10 * v));
    }
  }
  // BT.601 video range, as cameras' YUYV and librealsense's own conversion are.
  auto luma = [](cv::Vec3b c) { return 16 + 0.257 * c[2] + 0.504 * c[1] + 0.098 * c[0]; };
  auto u_of = [](cv::Vec3b c) { return 128 - 0.148 * c[2] - 0.291 * c[1] + 0.439 * c[0]; };
  auto v_of = [](cv::Vec3b c) { return 128 + 0.439 * c[2] - 0.368 * c[1] - 0.071 * c[0]; };
  auto byte = [](double x) { return static_cast<std::uint8_t>(std::lround(x)); };
  std::vector<std::uint8_t> packed;  // Y0 U Y1 V per pair of pixels
  for (int v = 0; v < bgr.rows; ++v) {
    for (int u = 0; u < bgr.cols; u += 2) {
      const cv::Vec3b a = bgr.at<cv::Vec3b>(v, u), b = bgr.at<cv::Vec3b>(v, u + 1);
      packed.insert(packed.end(), {byte(luma(a)), byte(u_of(a)), byte(luma(b)), byte(v_of(a))});
    }
  }
  RosImage image;
  image.width = 8;
  image.height = 4;
  image.encoding = "YUYV";
  image.step = 16;
  image.data = packed.data();
  image.size = packed.size();
  const cv::Mat decoded = ColorFromRosImage(image, "test");
  ASSERT_EQ(decoded.size(), bgr.size());
  cv::Mat difference;
  cv::absdiff(decoded, bgr, difference);
  double worst = 0.0;
  cv::minMaxLoc(difference.reshape(1), nullptr, &worst);
  EXPECT_LE(worst, 3.0);
}

}  // namespace
}  // namespace stillmap
