#include "bag/bag_streams.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <set>

#include "bag/image_judge.h"
#include "stillmap/io/error.h"
#include "stillmap/io/option_names.h"
#include "stillmap/io/sequence.h"

namespace stillmap {
namespace {

bool EndsWith(const std::string& text, const std::string& end) {
  return text.size() >= end.size() && text.compare(text.size() - end.size(), end.size(), end) == 0;
}

// `part` in `text`, in any letter case (the RealSense recorder's topics say Color_0, Depth_0).
bool Contains(const std::string& text, const char* part) {
  return LowerCase(text).find(LowerCase(part)) != std::string::npos;
}

BagStreamKind KindOf(const std::string& type) {
  if (EndsWith(type, "sensor_msgs/Image") || EndsWith(type, "sensor_msgs/msg/Image")) {
    return BagStreamKind::kImage;
  }
  if (EndsWith(type, "/CompressedImage")) return BagStreamKind::kCompressedImage;
  if (EndsWith(type, "/CameraInfo")) return BagStreamKind::kCameraInfo;
  return BagStreamKind::kOther;
}

// The topic without its image_transport suffix: /x/image_raw for /x/image_raw/compressed.
std::string BaseTopic(const std::string& name) {
  for (const char* suffix : {"/compressedDepth", "/compressed"}) {
    if (EndsWith(name, suffix)) return name.substr(0, name.size() - std::string(suffix).size());
  }
  return name;
}

std::string Namespace(const std::string& topic) {
  const size_t slash = topic.rfind('/');
  return slash == std::string::npos ? std::string() : topic.substr(0, slash);
}

bool IsColor(const BagStream& s) {
  if (s.kind == BagStreamKind::kImage) {
    const std::string encoding = LowerCase(s.detail);
    for (const char* colour : {"rgb8", "bgr8", "rgba8", "bgra8", "yuyv", "yuv422", "uyvy"}) {
      if (encoding.compare(0, std::string(colour).size(), colour) == 0) return true;
    }
    return encoding == "mono8" && (Contains(s.name, "rgb") || Contains(s.name, "color"));
  }
  return s.kind == BagStreamKind::kCompressedImage && !Contains(s.detail, "compressedDepth") &&
         !Contains(s.detail, "rvl") && !Contains(s.name, "depth");
}

bool IsDepth(const BagStream& s) {
  if (s.kind == BagStreamKind::kImage) {
    return (s.detail == "16UC1" || s.detail == "32FC1" || s.detail == "mono16") &&
           Contains(s.name, "depth");
  }
  return s.kind == BagStreamKind::kCompressedImage && Contains(s.detail, "compressedDepth");
}

// Depth registered to colour, by the names the drivers give it.
bool IsRegistered(const std::string& name) {
  return Contains(name, "aligned_depth_to_color") || Contains(name, "depth_registered") ||
         Contains(name, "depth_to_rgb") || Contains(name, "registered");
}

// One stream per base topic, the raw one preferred over its compressed transport.
std::vector<size_t> OnePerBase(const BagContents& contents, const std::vector<size_t>& found) {
  std::map<std::string, size_t> by_base;
  for (const size_t i : found) {
    const std::string base = BaseTopic(contents.streams[i].name);
    const auto it = by_base.find(base);
    if (it == by_base.end() || contents.streams[i].kind == BagStreamKind::kImage) by_base[base] = i;
  }
  std::vector<size_t> out;
  out.reserve(by_base.size());
  for (const auto& entry : by_base) out.push_back(entry.second);
  return out;
}

size_t Named(const BagContents& contents, const std::string& name, const char* what,
             const std::string& path) {
  for (size_t i = 0; i < contents.streams.size(); ++i) {
    if (contents.streams[i].name == name && contents.streams[i].count > 0) return i;
  }
  throw InputError(path + ": no topic " + Quoted(name) + " for " + what + "; the bag holds:\n" +
                   DescribeBagStreams(contents));
}

size_t PickOne(const BagContents& contents, const std::vector<size_t>& found, const char* what,
               const char* option, const std::string& path) {
  if (found.size() == 1) return found[0];
  const std::string start =
      path + (found.empty() ? ": no " : ": more than one ") + what + " stream" +
      (found.empty() ? "" : " (choose one with --topic " + std::string(option) + "=NAME)");
  throw InputError(start + "; the bag holds:\n" + DescribeBagStreams(contents));
}

}  // namespace

namespace {

bool SameIntrinsics(const RosCameraInfo& a, const RosCameraInfo& b) {
  return a.width == b.width && a.height == b.height && a.k == b.k && a.d == b.d &&
         a.distortion_model == b.distortion_model;
}

}  // namespace

namespace {

// A camera-info message of `stream` (message.topic): the first is kept, a librealsense model
// restated (said in a note, and in a warning when plumb_bob fits it coarsely); the time of the
// first later one that differs goes to *changed.
void ScanCameraInfo(const BagMessage& message, BagSerialization serialization,
                    const std::string& path, BagStream* stream, std::map<size_t, double>* changed,
                    BagContents* contents) {
  RosCameraInfo info;
  std::string error;
  if (!DecodeRosCameraInfo(message.data, message.size, serialization, &info, &error)) return;
  const std::string model = info.distortion_model;
  double fit_px = 0.0;
  if (RestateRealSenseModel(&info, &fit_px) && !stream->has_info && fit_px > 0.0) {
    char worst[32];
    std::snprintf(worst, sizeof(worst), "%.3f px", fit_px);
    contents->notes.push_back(stream->name + ": distortion " + Quoted(model) +
                              " restated as the plumb_bob fitted to it (largest difference " +
                              worst + ")");
    if (fit_px > 0.1) {
      contents->warnings.push_back(
          path + ": " + stream->name + ": its distortion model is matched by plumb_bob only to " +
          worst +
          fmt::format("; give {} if that is too coarse", OptionKey(&CameraOverrides::distortion)));
    }
  }
  if (!stream->has_info) {
    stream->info = info;
    stream->has_info = true;
  } else if (!changed->count(message.topic) && !SameIntrinsics(stream->info, info)) {
    (*changed)[message.topic] = message.time;
  }
}

// What the scan met beyond the images, in warnings: camera infos that change, a topic with two
// types, messages of the RealSense description or /tf_static that do not decode.
TransformSample SampleOf(const RosTransform& transform) {
  TransformSample sample;
  sample.parent = transform.parent;
  sample.child = transform.child;
  sample.stamp = transform.stamp;
  sample.translation = {transform.translation[0], transform.translation[1],
                        transform.translation[2]};
  sample.rotation = {transform.rotation[3], transform.rotation[0], transform.rotation[1],
                     transform.rotation[2]};
  return sample;
}

// Keeps what a message of /tf or an odometry topic says of where frames are (/tf_static's are
// decoded once, for the depth registration too, and taken after the scan).
void RecordPoses(const BagStream& stream, const BagMessage& message, BagSerialization serialization,
                 RecordedPoses* poses) {
  const bool tf_message = stream.type.find("TFMessage") != std::string::npos;
  const bool is_tf = tf_message && (stream.name == "/tf" || stream.name == "tf");
  const bool odometry = stream.type.find("Odometry") != std::string::npos;
  if (!is_tf && !odometry) return;
  std::string error;
  if (odometry) {
    RosTransform pose;
    if (DecodeRosOdometry(message.data, message.size, serialization, &pose, &error)) {
      poses->odometry[stream.name].push_back(SampleOf(pose));
    } else {
      ++poses->undecoded[stream.name];
    }
    return;
  }
  std::vector<RosTransform> transforms;
  if (!DecodeRosTfMessage(message.data, message.size, serialization, &transforms, &error)) {
    ++poses->undecoded[stream.name];
    return;
  }
  for (const RosTransform& transform : transforms) poses->tf.push_back(SampleOf(transform));
}

void WarnOfScan(const std::string& path, const std::map<size_t, double>& info_changed,
                size_t undecoded_transforms, BagContents* contents) {
  for (const auto& [index, time] : info_changed) {
    char when[32];
    std::snprintf(when, sizeof(when), "%.3f", time);
    contents->warnings.push_back(path + ": the CameraInfo on " + contents->streams[index].name +
                                 " changes at t = " + when +
                                 " s (size, K or distortion); its first message is used for every "
                                 "frame");
  }
  for (size_t i = 0; i < contents->streams.size(); ++i) {
    for (size_t j = 0; j < i; ++j) {
      if (contents->streams[j].name != contents->streams[i].name) continue;
      contents->warnings.push_back(path + ": topic " + contents->streams[i].name +
                                   " carries two types (" + contents->streams[j].type + ", " +
                                   contents->streams[i].type +
                                   "); each is read as its own, and --topic takes the first");
    }
  }
  if (contents->realsense.undecoded > 0) {
    contents->warnings.push_back(path + ": " + std::to_string(contents->realsense.undecoded) +
                                 " RealSense device, extrinsic or option messages that do not "
                                 "decode are left out");
  }
  if (undecoded_transforms > 0) {
    contents->warnings.push_back(path + ": " + std::to_string(undecoded_transforms) +
                                 " /tf_static messages that do not decode are left out");
  }
}

}  // namespace

BagContents ScanBagContents(BagReader& bag) {
  BagContents contents;
  std::map<size_t, ImageMessages> images;  // by stream
  std::map<size_t, double> info_changed;   // camera-info streams: when the intrinsics change
  std::vector<RealSenseTopic> realsense;   // per stream
  std::vector<std::string> scan_warnings;  // said after the reader's own
  size_t undecoded_transforms = 0;
  bag.Scan([&](const BagMessage& message) {
    for (size_t t = contents.streams.size(); t < bag.topics().size(); ++t) {
      BagStream stream;
      stream.name = bag.topics()[t].name;
      stream.type = bag.topics()[t].type;
      stream.kind = KindOf(stream.type);
      realsense.push_back(ClassifyRealSenseTopic(stream.name));
      contents.streams.push_back(std::move(stream));
    }
    BagStream& stream = contents.streams[message.topic];
    std::string error;
    if (stream.kind == BagStreamKind::kImage || stream.kind == BagStreamKind::kCompressedImage) {
      double stamp = message.time;
      const std::string key = ImageKey(stream, message, bag.serialization(), &stamp);
      images[message.topic].Add(key, stamp, message.position);
      RosHeader header;
      if (stream.frame_id.empty() &&
          DecodeRosHeader(message.data, message.size, bag.serialization(), &header, &error)) {
        stream.frame_id = header.frame_id;
      }
      return;
    }
    RecordPoses(stream, message, bag.serialization(), &contents.poses);
    if (stream.kind == BagStreamKind::kOther && stream.name == "/tf_static" &&
        stream.type.find("TFMessage") != std::string::npos &&
        !DecodeRosTfMessage(message.data, message.size, bag.serialization(),
                            &contents.static_transforms, &error)) {
      ++undecoded_transforms;
    }
    if (stream.kind == BagStreamKind::kOther && realsense[message.topic] != RealSenseTopic::kNone) {
      AddRealSenseDetail(realsense[message.topic], stream.name, message.data, message.size,
                         bag.serialization(), &contents.realsense);
    }
    if (stream.kind == BagStreamKind::kCameraInfo) {
      ScanCameraInfo(message, bag.serialization(), bag.path(), &stream, &info_changed, &contents);
    }
    if (stream.count == 0 || message.time < stream.first_stamp) stream.first_stamp = message.time;
    stream.last_stamp = std::max(stream.last_stamp, message.time);
    ++stream.count;
  });
  for (const RosTransform& transform : contents.static_transforms) {
    contents.poses.tf_static.push_back(SampleOf(transform));
  }
  contents.truncated = bag.truncated();
  scan_warnings.swap(contents.warnings);  // the fit warnings met during the scan
  contents.warnings = bag.warnings();
  for (const auto& [index, messages] : images) {
    JudgeImages(messages, bag.path(), &contents.streams[index], &contents.warnings);
  }
  WarnOfScan(bag.path(), info_changed, undecoded_transforms, &contents);
  contents.warnings.insert(contents.warnings.end(), scan_warnings.begin(), scan_warnings.end());
  return contents;
}

BagChoice ChooseBagStreams(const BagContents& contents, const BagTopicNames& names,
                           bool camera_given, const std::string& path) {
  std::vector<size_t> colors, depths;
  for (size_t i = 0; i < contents.streams.size(); ++i) {
    const BagStream& stream = contents.streams[i];
    if (stream.count == 0) continue;
    if (IsColor(stream)) colors.push_back(i);
    if (IsDepth(stream)) depths.push_back(i);
  }
  colors = OnePerBase(contents, colors);
  depths = OnePerBase(contents, depths);
  std::vector<size_t> registered;
  for (const size_t i : depths) {
    if (IsRegistered(contents.streams[i].name)) registered.push_back(i);
  }
  if (!registered.empty()) depths = registered;
  BagChoice choice;
  choice.color = names.color.empty() ? PickOne(contents, colors, "colour", "color", path)
                                     : Named(contents, names.color, "colour", path);
  choice.depth = names.depth.empty() ? PickOne(contents, depths, "depth", "depth", path)
                                     : Named(contents, names.depth, "depth", path);
  if (!names.camera_info.empty()) {
    choice.camera_info = Named(contents, names.camera_info, "the camera info", path);
  } else {
    const std::string wanted = CameraInfoTopicOf(contents.streams[choice.color].name);
    for (size_t i = 0; i < contents.streams.size(); ++i) {
      if (contents.streams[i].name == wanted && contents.streams[i].has_info) {
        choice.camera_info = i;
        break;
      }
    }
    if (choice.camera_info == BagChoice::kNone && camera_given) return choice;
    if (choice.camera_info == BagChoice::kNone) {
      throw InputError(
          path + ": no camera info beside the colour topic (" + wanted +
          fmt::format("); name one with --topic camera_info=NAME, or give the camera with "
                      "--set {}=NAME or with {}, {}, {} and "
                      "{} (the image size is then the colour images'); the bag holds:\n",
                      OptionKey(&CameraOverrides::preset), OptionKey(&CameraOverrides::fx),
                      OptionKey(&CameraOverrides::fy), OptionKey(&CameraOverrides::cx),
                      OptionKey(&CameraOverrides::cy)) +
          DescribeBagStreams(contents));
    }
  }
  if (!contents.streams[choice.camera_info].has_info) {
    throw InputError(path + ": topic " + contents.streams[choice.camera_info].name +
                     " holds no readable sensor_msgs/CameraInfo");
  }
  return choice;
}

std::string CameraInfoTopicOf(const std::string& image_topic) {
  const std::string stream = RealSenseStreamOf(image_topic);
  if (!stream.empty()) return stream + "/info/camera_info";
  return Namespace(BaseTopic(image_topic)) + "/camera_info";
}

std::string DescribeBagStreams(const BagContents& contents) {
  std::string text;
  for (const BagStream& stream : contents.streams) {
    const double span = stream.last_stamp - stream.first_stamp;
    const double rate = stream.count > 1 && span > 0.0 ? (stream.count - 1) / span : 0.0;
    char line[512];
    std::snprintf(line, sizeof(line), "  %-50s %-32s %-28s %6zu messages %6.1f Hz\n",
                  Quoted(stream.name, 200).c_str(), Quoted(stream.type).c_str(),
                  Quoted(stream.detail).c_str(), stream.count, rate);
    text += line;
  }
  if (text.empty()) text = "  (no messages)\n";
  return text;
}

}  // namespace stillmap
