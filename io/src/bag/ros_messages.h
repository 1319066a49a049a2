// The sensor_msgs messages an RGB-D build needs, decoded from either serialization (ROS 1's, or
// ROS 2's CDR, little-endian; written by stillmap since neither has a Debian package that reads
// it without a ROS installation): Image, CompressedImage and CameraInfo, and any message's
// std_msgs/Header. Image data is referenced, not copied: it lives as long as the message bytes.
#pragma once

#include <array>
#include <cstdint>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "stillmap/io/bag_reader.h"

namespace stillmap {

struct RosHeader {
  double stamp = 0.0;  // [s]
  std::string frame_id;
};

struct RosImage {
  RosHeader header;
  std::uint32_t height = 0, width = 0;
  std::string encoding;
  bool big_endian = false;
  std::uint32_t step = 0;
  const std::uint8_t* data = nullptr;
  size_t size = 0;
};

struct RosCompressedImage {
  RosHeader header;
  std::string format;
  const std::uint8_t* data = nullptr;
  size_t size = 0;
};

struct RosCameraInfo {
  RosHeader header;
  std::uint32_t height = 0, width = 0;
  std::string distortion_model;
  std::vector<double> d;
  std::array<double, 9> k{};
};

// One geometry_msgs/TransformStamped of a tf2_msgs/TFMessage: the pose of `child` in `parent`.
struct RosTransform {
  double stamp = 0.0;  // [s] (its header's; 0 for a bare geometry_msgs/Transform)
  std::string parent, child;
  std::array<double, 3> translation{};  // [m]
  std::array<double, 4> rotation{};     // quaternion x, y, z, w
};

// `text` in lower case (ASCII): encodings and topic names are compared in any letter case.
std::string LowerCase(std::string text);

// Each returns false with *error saying what does not fit when the bytes are not such a message.
bool DecodeRosHeader(const std::uint8_t* data, size_t size, BagSerialization serialization,
                     RosHeader* header, std::string* error);
bool DecodeRosImage(const std::uint8_t* data, size_t size, BagSerialization serialization,
                    RosImage* image, std::string* error);
bool DecodeRosCompressedImage(const std::uint8_t* data, size_t size, BagSerialization serialization,
                              RosCompressedImage* image, std::string* error);
bool DecodeRosCameraInfo(const std::uint8_t* data, size_t size, BagSerialization serialization,
                         RosCameraInfo* info, std::string* error);
// A tf2_msgs/TFMessage (what /tf_static carries): its transforms appended to *transforms.
bool DecodeRosTfMessage(const std::uint8_t* data, size_t size, BagSerialization serialization,
                        std::vector<RosTransform>* transforms, std::string* error);

// A nav_msgs/Odometry's pose: that of `child` (child_frame_id) in `parent` (the header's frame_id)
// at `stamp`; the covariances and twist are not read.
bool DecodeRosOdometry(const std::uint8_t* data, size_t size, BagSerialization serialization,
                       RosTransform* pose, std::string* error);

// geometry_msgs/Transform, std_msgs/Float32 and diagnostic_msgs/KeyValue: what the RealSense
// recorder writes beside its images (extrinsics, options, device info).
bool DecodeRosTransform(const std::uint8_t* data, size_t size, BagSerialization serialization,
                        RosTransform* transform, std::string* error);
bool DecodeRosFloat32(const std::uint8_t* data, size_t size, BagSerialization serialization,
                      float* value, std::string* error);
bool DecodeRosKeyValue(const std::uint8_t* data, size_t size, BagSerialization serialization,
                       std::string* key, std::string* value, std::string* error);

// Colour as CV_8UC3 BGR (a copy) from rgb8, bgr8, rgba8, bgra8, mono8 or 4:2:2 YUV (yuyv,
// yuv422), in any letter case. Throws InputError naming `where` for another encoding or data
// shorter than its rows.
cv::Mat ColorFromRosImage(const RosImage& image, const std::string& where);
// Depth in metres (CV_32FC1, 0 = no reading) from 16UC1 or mono16 (metres_per_unit each: 0.001
// for ROS's millimetres) or 32FC1 (metres; NaN and inf = no reading).
cv::Mat DepthFromRosImage(const RosImage& image, double metres_per_unit, const std::string& where);
// Colour from a JPEG or PNG CompressedImage.
cv::Mat ColorFromRosCompressed(const RosCompressedImage& image, const std::string& where);
// Depth from compressed_depth_image_transport's "16UC1; compressedDepth png" (12-byte header,
// then a 16-bit PNG), "16UC1; compressedDepth rvl" (12-byte header, columns and rows, then RVL),
// or their 32FC1 forms (inverse depth quantized by the header's two parameters).
cv::Mat DepthFromRosCompressed(const RosCompressedImage& image, double metres_per_unit,
                               const std::string& where);

}  // namespace stillmap
