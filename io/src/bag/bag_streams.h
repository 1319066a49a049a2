// What a bag holds for an RGB-D build, found in one pass: each image topic's header stamps and
// message positions, each camera-info topic's first message; and the choice of the colour, depth
// and camera-info topics, by type, encoding and the names ROS camera drivers use.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "bag/realsense_layout.h"
#include "bag/ros_messages.h"
#include "stillmap/io/bag_reader.h"
#include "stillmap/io/sequence.h"

namespace stillmap {

enum class BagStreamKind { kOther, kImage, kCompressedImage, kCameraInfo };

struct BagStream {
  std::string name, type;
  BagStreamKind kind = BagStreamKind::kOther;
  std::string frame_id;       // images: their first message's header frame_id
  std::string detail;         // images: the encoding or compressed format most of its messages have
  int width = 0, height = 0;  // raw images: the size most of its messages have [px]
  size_t count = 0;           // images: the messages kept (those of `detail` and that size)
  size_t skipped = 0;         // images: messages left out (no image, or another encoding or size)
  size_t repeated = 0;        // images: messages left out for repeating an earlier header stamp
  double first_stamp = 0.0, last_stamp = 0.0;  // header stamps [s] (record times for others)
  std::vector<double> stamps;                  // images: header stamp per message
  std::vector<BagPosition> positions;          // images: where each message lies
  bool has_info = false;
  RosCameraInfo info;  // camera info: its first message
};

struct BagContents {
  std::vector<BagStream> streams;               // per topic of the reader
  std::vector<RosTransform> static_transforms;  // every /tf_static message's
  RecordedPoses poses;                          // /tf, /tf_static, odometry (issue 48)
  RealSenseDetails realsense;                   // a RealSense recorder bag's description
  bool truncated = false;
  std::vector<std::string> warnings;
  std::vector<std::string> notes;  // how the bag was read (a distortion model restated)
};

// Scans the whole bag once. An image topic is judged by its messages: those of the encoding (or
// format) and size most of them have are kept; the others (no image, no readable header, another
// encoding or size) are left out and counted in a warning.
BagContents ScanBagContents(BagReader& bag);

// The topics a build uses; empty names are chosen automatically.
struct BagTopicNames {
  std::string color, depth, camera_info;
};

struct BagChoice {
  static constexpr size_t kNone = static_cast<size_t>(-1);
  size_t color = 0, depth = 0;  // indices into BagContents::streams
  size_t camera_info = kNone;   // kNone: no CameraInfo used (the camera was given)
};

// Chooses the streams (the named ones when given). Without a CameraInfo beside the colour topic,
// `camera_given` (a preset or the intrinsics set by the user) lets the build go on without one.
// Throws InputError naming the bag, saying which stream is missing or ambiguous and listing the
// topics with their type and count.
BagChoice ChooseBagStreams(const BagContents& contents, const BagTopicNames& names,
                           bool camera_given, const std::string& path);

// The camera-info topic that drivers publish beside an image topic: /x/camera_info for
// /x/image_raw and its transports (/x/image_raw/compressed); the RealSense recorder's
// /device_0/sensor_1/Color_0/info/camera_info for /device_0/sensor_1/Color_0/image/data.
std::string CameraInfoTopicOf(const std::string& image_topic);

// One line per topic: name, type, encoding or format, count and rate.
std::string DescribeBagStreams(const BagContents& contents);

}  // namespace stillmap
