#include "bag/bag_streams.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "stillmap/io/error.h"

namespace stillmap {
namespace {

bool EndsWith(const std::string& text, const std::string& end) {
  return text.size() >= end.size() && text.compare(text.size() - end.size(), end.size(), end) == 0;
}

bool Contains(const std::string& text, const char* part) {
  return text.find(part) != std::string::npos;
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
    if (s.detail == "rgb8" || s.detail == "bgr8" || s.detail == "rgba8" || s.detail == "bgra8") {
      return true;
    }
    return s.detail == "mono8" && (Contains(s.name, "rgb") || Contains(s.name, "color"));
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

BagContents ScanBagContents(BagReader& bag) {
  BagContents contents;
  size_t undecoded = 0, undecoded_transforms = 0;
  bag.Scan([&](const BagMessage& message) {
    if (contents.streams.size() < bag.topics().size()) {
      for (size_t t = contents.streams.size(); t < bag.topics().size(); ++t) {
        BagStream stream;
        stream.name = bag.topics()[t].name;
        stream.type = bag.topics()[t].type;
        stream.kind = KindOf(stream.type);
        contents.streams.push_back(std::move(stream));
      }
    }
    BagStream& stream = contents.streams[message.topic];
    std::string error;
    double stamp = message.time;
    if (stream.kind == BagStreamKind::kOther && stream.name == "/tf_static" &&
        stream.type.find("TFMessage") != std::string::npos &&
        !DecodeRosTfMessage(message.data, message.size, bag.serialization(),
                            &contents.static_transforms, &error)) {
      ++undecoded_transforms;
    }
    if (stream.kind == BagStreamKind::kCameraInfo && !stream.has_info) {
      stream.has_info = DecodeRosCameraInfo(message.data, message.size, bag.serialization(),
                                            &stream.info, &error);
    } else if (stream.kind == BagStreamKind::kImage ||
               stream.kind == BagStreamKind::kCompressedImage) {
      if (stream.count == 0) {
        RosImage image;
        RosCompressedImage compressed;
        if (stream.kind == BagStreamKind::kImage &&
            DecodeRosImage(message.data, message.size, bag.serialization(), &image, &error)) {
          stream.detail = image.encoding;
        } else if (stream.kind == BagStreamKind::kCompressedImage &&
                   DecodeRosCompressedImage(message.data, message.size, bag.serialization(),
                                            &compressed, &error)) {
          stream.detail = compressed.format;
        }
      }
      RosHeader header;
      if (!DecodeRosHeader(message.data, message.size, bag.serialization(), &header, &error)) {
        ++undecoded;
        return;
      }
      stamp = header.stamp;
      stream.stamps.push_back(stamp);
      stream.positions.push_back(message.position);
    }
    if (stream.count == 0 || stamp < stream.first_stamp) stream.first_stamp = stamp;
    stream.last_stamp = std::max(stream.last_stamp, stamp);
    ++stream.count;
  });
  contents.truncated = bag.truncated();
  contents.warnings = bag.warnings();
  if (undecoded > 0) {
    contents.warnings.push_back(bag.path() + ": " + std::to_string(undecoded) +
                                " image messages without a readable header are left out");
  }
  if (undecoded_transforms > 0) {
    contents.warnings.push_back(bag.path() + ": " + std::to_string(undecoded_transforms) +
                                " /tf_static messages that do not decode are left out");
  }
  return contents;
}

BagChoice ChooseBagStreams(const BagContents& contents, const BagTopicNames& names,
                           const std::string& path) {
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
    std::vector<size_t> found;
    for (size_t i = 0; i < contents.streams.size(); ++i) {
      if (contents.streams[i].name == wanted && contents.streams[i].has_info) found.push_back(i);
    }
    if (found.empty()) {
      throw InputError(path + ": no camera info beside the colour topic (" + wanted +
                       "); name one with --topic camera_info=NAME, or give the camera with "
                       "--set camera.preset=... or camera.fx, fy, cx, cy; the bag holds:\n" +
                       DescribeBagStreams(contents));
    }
    choice.camera_info = found[0];
  }
  if (!contents.streams[choice.camera_info].has_info) {
    throw InputError(path + ": topic " + contents.streams[choice.camera_info].name +
                     " holds no readable sensor_msgs/CameraInfo");
  }
  return choice;
}

std::string CameraInfoTopicOf(const std::string& image_topic) {
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
