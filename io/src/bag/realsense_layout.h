// The layout librealsense's own recorder writes (RealSense Viewer, rs-record, rs2::recorder):
// ROS 1 bags whose streams live under /device_<d>/sensor_<s>/<Stream>_<i>/ (image/data,
// info/camera_info, tf/<group>), with the sensors' options under /device_<d>/sensor_<s>/option/
// and the device's description on /device_<d>/info. What a build needs from it beside the images:
// the depth scale (the Depth Units option), the extrinsics that register depth to colour, the
// distortion models by their librealsense names, and the device's name for `info`.
#pragma once

#include <Eigen/Geometry>
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "bag/ros_messages.h"

namespace stillmap {

enum class RealSenseTopic { kNone, kDeviceInfo, kSensorInfo, kExtrinsic, kDepthUnits };

struct RealSenseDetails {
  std::vector<std::pair<std::string, std::string>> device;  // /device_<d>/info: key, value
  std::map<std::string, std::string> sensor_names;          // by sensor ("/device_0/sensor_0")
  // By stream ("/device_0/sensor_0/Depth_0"), then extrinsic group: the transform that takes a
  // point of the group's reference stream into this stream (librealsense's rs2_extrinsics).
  std::map<std::string, std::map<std::string, RosTransform>> stream_from_reference;
  std::map<std::string, double> depth_units;  // by sensor [m per unit]
  size_t undecoded = 0;                       // messages of these topics that did not decode
};

// Which of the recorder's description topics `topic` is (kNone for images and other topics).
RealSenseTopic ClassifyRealSenseTopic(const std::string& topic);
// The stream of a recorder image topic: "/device_0/sensor_0/Depth_0" for
// "/device_0/sensor_0/Depth_0/image/data"; empty for any other topic.
std::string RealSenseStreamOf(const std::string& topic);
// The sensor of a stream: "/device_0/sensor_0" for "/device_0/sensor_0/Depth_0".
std::string RealSenseSensorOf(const std::string& stream);

// Keeps what one message of a description topic says (`kind` from ClassifyRealSenseTopic).
void AddRealSenseDetail(RealSenseTopic kind, const std::string& topic, const std::uint8_t* data,
                        size_t size, BagSerialization serialization, RealSenseDetails* details);

// The depth stream's pose in the colour stream, through an extrinsic group both belong to.
std::optional<Eigen::Isometry3d> RealSenseColorFromDepth(const RealSenseDetails& details,
                                                         const std::string& color_stream,
                                                         const std::string& depth_stream);

// A CameraInfo whose distortion model has a librealsense name ("None", "Brown Conrady",
// "Inverse Brown Conrady", "Modified Brown Conrady", "Kannala Brandt4", "Ftheta") restated in
// ROS's plumb_bob: all-zero coefficients are no distortion; Brown Conrady is plumb_bob itself;
// the inverse and modified forms with coefficients are replaced by the plumb_bob fitted to them
// over the image (*fit_error_px: the largest difference, in pixels). False, and *info untouched,
// for another model name, or a fisheye model with coefficients.
bool RestateRealSenseModel(RosCameraInfo* info, double* fit_error_px);

// "Intel RealSense D435 (serial ..., firmware ...); sensors: Stereo Module, RGB Camera"; empty when
// the bag holds no device description.
std::string DescribeRealSenseDevice(const RealSenseDetails& details);

}  // namespace stillmap
