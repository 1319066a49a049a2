#include "bag/ros_messages.h"

#include <cctype>
#include <cmath>
#include <cstring>
#include <opencv2/imgproc.hpp>

#include "bag/bytes.h"
#include "bag/rvl.h"
#include "jpeg_decoder.h"
#include "png_decoder.h"
#include "stillmap/io/error.h"

namespace stillmap {
namespace {

constexpr int kMaxSide = 16384;  // [px]; larger claims are damage

// Reads fields in order. CDR aligns each primitive to its size, counted from after the 4-byte
// encapsulation header; ROS 1 packs them.
class Cursor {
 public:
  Cursor(const std::uint8_t* data, size_t size, BagSerialization serialization)
      : data_(data), size_(size), cdr_(serialization == BagSerialization::kCdr) {
    if (!cdr_) return;
    // CDR_LE or PL_CDR_LE (0x00 0x01 / 0x00 0x03); big-endian CDR is not written by ROS 2 on any
    // platform it supports.
    ok_ = size >= 4 && data[0] == 0 && (data[1] == 1 || data[1] == 3);
    position_ = origin_ = 4;
  }
  bool ok() const { return ok_; }
  bool U8(std::uint8_t* value) {
    if (!Take(1, 1)) return false;
    *value = data_[position_ - 1];
    return true;
  }
  bool U32(std::uint32_t* value) {
    if (!Take(4, 4)) return false;
    *value = Le32(data_ + position_ - 4);
    return true;
  }
  bool F32(float* value) {
    if (!Take(4, 4)) return false;
    const std::uint32_t bits = Le32(data_ + position_ - 4);
    std::memcpy(value, &bits, sizeof(*value));
    return true;
  }
  bool F64(double* value) {
    if (!Take(8, 8)) return false;
    *value = LeDouble(data_ + position_ - 8);
    return true;
  }
  bool String(std::string* value) {
    std::uint32_t length = 0;
    if (!U32(&length) || length > size_ - position_) return ok_ = false;
    const char* text = reinterpret_cast<const char*>(data_ + position_);
    size_t used = length;
    if (cdr_ && used > 0 && text[used - 1] == '\0') --used;  // CDR counts the terminator
    value->assign(text, used);
    position_ += length;
    return true;
  }
  bool Bytes(const std::uint8_t** data, size_t* size) {
    std::uint32_t length = 0;
    if (!U32(&length) || length > size_ - position_) return ok_ = false;
    *data = data_ + position_;
    *size = length;
    position_ += length;
    return true;
  }
  bool F64Sequence(std::vector<double>* values, std::uint32_t max_count) {
    std::uint32_t count = 0;
    if (!U32(&count) || count > max_count) return ok_ = false;
    values->resize(count);
    for (double& value : *values) {
      if (!F64(&value)) return false;
    }
    return true;
  }

 private:
  bool Take(size_t bytes, size_t alignment) {
    if (!ok_) return false;
    if (cdr_) position_ = origin_ + (position_ - origin_ + alignment - 1) / alignment * alignment;
    if (position_ > size_ || size_ - position_ < bytes) return ok_ = false;
    position_ += bytes;
    return true;
  }

  const std::uint8_t* data_;
  size_t size_;
  bool cdr_;
  bool ok_ = true;
  size_t position_ = 0, origin_ = 0;
};

bool Header(Cursor& cursor, BagSerialization serialization, RosHeader* header) {
  std::uint32_t seq = 0, seconds = 0, nanoseconds = 0;
  if (serialization == BagSerialization::kRos1 && !cursor.U32(&seq)) return false;
  if (!cursor.U32(&seconds) || !cursor.U32(&nanoseconds)) return false;
  // ROS 2's seconds are signed (builtin_interfaces/Time); ROS 1's are not.
  const double whole = serialization == BagSerialization::kCdr
                           ? static_cast<double>(static_cast<std::int32_t>(seconds))
                           : static_cast<double>(seconds);
  header->stamp = whole + 1e-9 * static_cast<double>(nanoseconds);
  return cursor.String(&header->frame_id);
}

bool Fail(std::string* error, const char* what) {
  *error = what;
  return false;
}

}  // namespace

std::string LowerCase(std::string text) {
  for (char& c : text) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return text;
}

bool DecodeRosHeader(const std::uint8_t* data, size_t size, BagSerialization serialization,
                     RosHeader* header, std::string* error) {
  Cursor cursor(data, size, serialization);
  if (!Header(cursor, serialization, header)) return Fail(error, "no std_msgs/Header");
  return true;
}

bool DecodeRosImage(const std::uint8_t* data, size_t size, BagSerialization serialization,
                    RosImage* image, std::string* error) {
  Cursor cursor(data, size, serialization);
  std::uint8_t big_endian = 0;
  if (!Header(cursor, serialization, &image->header) || !cursor.U32(&image->height) ||
      !cursor.U32(&image->width) || !cursor.String(&image->encoding) || !cursor.U8(&big_endian) ||
      !cursor.U32(&image->step) || !cursor.Bytes(&image->data, &image->size)) {
    return Fail(error, "not a sensor_msgs/Image (its fields run past the message)");
  }
  image->big_endian = big_endian != 0;
  if (image->width == 0 || image->height == 0 || image->width > kMaxSide ||
      image->height > kMaxSide) {
    return Fail(error, "a sensor_msgs/Image of impossible size");
  }
  return true;
}

bool DecodeRosCompressedImage(const std::uint8_t* data, size_t size, BagSerialization serialization,
                              RosCompressedImage* image, std::string* error) {
  Cursor cursor(data, size, serialization);
  if (!Header(cursor, serialization, &image->header) || !cursor.String(&image->format) ||
      !cursor.Bytes(&image->data, &image->size)) {
    return Fail(error, "not a sensor_msgs/CompressedImage (its fields run past the message)");
  }
  return true;
}

bool DecodeRosCameraInfo(const std::uint8_t* data, size_t size, BagSerialization serialization,
                         RosCameraInfo* info, std::string* error) {
  Cursor cursor(data, size, serialization);
  if (!Header(cursor, serialization, &info->header) || !cursor.U32(&info->height) ||
      !cursor.U32(&info->width) || !cursor.String(&info->distortion_model) ||
      !cursor.F64Sequence(&info->d, 64)) {
    return Fail(error, "not a sensor_msgs/CameraInfo (its fields run past the message)");
  }
  for (double& k : info->k) {
    if (!cursor.F64(&k)) return Fail(error, "not a sensor_msgs/CameraInfo (no K matrix)");
  }
  return true;
}

bool DecodeRosTfMessage(const std::uint8_t* data, size_t size, BagSerialization serialization,
                        std::vector<RosTransform>* transforms, std::string* error) {
  Cursor cursor(data, size, serialization);
  std::uint32_t count = 0;
  constexpr std::uint32_t kMaxTransforms = 10000;
  if (!cursor.U32(&count) || count > kMaxTransforms) {
    return Fail(error, "not a tf2_msgs/TFMessage (no transform count)");
  }
  for (std::uint32_t i = 0; i < count; ++i) {
    RosHeader header;
    RosTransform transform;
    if (!Header(cursor, serialization, &header) || !cursor.String(&transform.child)) {
      return Fail(error, "not a tf2_msgs/TFMessage (a transform's frames run past the message)");
    }
    for (double& value : transform.translation) {
      if (!cursor.F64(&value)) return Fail(error, "not a tf2_msgs/TFMessage (no translation)");
    }
    for (double& value : transform.rotation) {
      if (!cursor.F64(&value)) return Fail(error, "not a tf2_msgs/TFMessage (no rotation)");
    }
    transform.parent = header.frame_id;
    transform.stamp = header.stamp;
    transforms->push_back(std::move(transform));
  }
  return true;
}

bool DecodeRosOdometry(const std::uint8_t* data, size_t size, BagSerialization serialization,
                       RosTransform* pose, std::string* error) {
  Cursor cursor(data, size, serialization);
  RosHeader header;
  if (!Header(cursor, serialization, &header) || !cursor.String(&pose->child)) {
    return Fail(error, "not a nav_msgs/Odometry (its frames run past the message)");
  }
  for (double& value : pose->translation) {
    if (!cursor.F64(&value)) return Fail(error, "not a nav_msgs/Odometry (no position)");
  }
  for (double& value : pose->rotation) {
    if (!cursor.F64(&value)) return Fail(error, "not a nav_msgs/Odometry (no orientation)");
  }
  pose->parent = header.frame_id;
  pose->stamp = header.stamp;
  return true;
}

bool DecodeRosTransform(const std::uint8_t* data, size_t size, BagSerialization serialization,
                        RosTransform* transform, std::string* error) {
  Cursor cursor(data, size, serialization);
  for (double& value : transform->translation) {
    if (!cursor.F64(&value)) return Fail(error, "not a geometry_msgs/Transform (no translation)");
  }
  for (double& value : transform->rotation) {
    if (!cursor.F64(&value)) return Fail(error, "not a geometry_msgs/Transform (no rotation)");
  }
  return true;
}

bool DecodeRosFloat32(const std::uint8_t* data, size_t size, BagSerialization serialization,
                      float* value, std::string* error) {
  Cursor cursor(data, size, serialization);
  return cursor.F32(value) || Fail(error, "not a std_msgs/Float32");
}

bool DecodeRosKeyValue(const std::uint8_t* data, size_t size, BagSerialization serialization,
                       std::string* key, std::string* value, std::string* error) {
  Cursor cursor(data, size, serialization);
  return (cursor.String(key) && cursor.String(value)) ||
         Fail(error, "not a diagnostic_msgs/KeyValue");
}

cv::Mat ColorFromRosImage(const RosImage& image, const std::string& where) {
  struct Layout {
    const char* encoding;
    int type;
    int to_bgr;  // cv::cvtColor code, -1 none
  };
  static const Layout kLayouts[] = {{"rgb8", CV_8UC3, cv::COLOR_RGB2BGR},
                                    {"bgr8", CV_8UC3, -1},
                                    {"rgba8", CV_8UC4, cv::COLOR_RGBA2BGR},
                                    {"bgra8", CV_8UC4, cv::COLOR_BGRA2BGR},
                                    {"mono8", CV_8UC1, cv::COLOR_GRAY2BGR},
                                    // 4:2:2, two bytes a pixel: ROS's yuv422 is UYVY; the
                                    // RealSense recorder writes YUYV
                                    {"yuyv", CV_8UC2, cv::COLOR_YUV2BGR_YUYV},
                                    {"yuv422_yuy2", CV_8UC2, cv::COLOR_YUV2BGR_YUYV},
                                    {"yuv422", CV_8UC2, cv::COLOR_YUV2BGR_UYVY},
                                    {"uyvy", CV_8UC2, cv::COLOR_YUV2BGR_UYVY}};
  const std::string encoding = LowerCase(image.encoding);
  for (const Layout& layout : kLayouts) {
    if (encoding != layout.encoding) continue;
    const size_t row = static_cast<size_t>(image.width) * CV_ELEM_SIZE(layout.type);
    if (image.step < row || image.size / image.step < image.height) {
      throw InputError(where + ": a " + image.encoding + " image whose data is shorter than " +
                       std::to_string(image.height) + " rows of " + std::to_string(row) + " bytes");
    }
    const cv::Mat view(static_cast<int>(image.height), static_cast<int>(image.width), layout.type,
                       const_cast<std::uint8_t*>(image.data), image.step);
    cv::Mat bgr;
    if (layout.to_bgr < 0) {
      bgr = view.clone();
    } else {
      cv::cvtColor(view, bgr, layout.to_bgr);
    }
    return bgr;
  }
  throw InputError(where + ": colour encoding " + Quoted(image.encoding) +
                   " is not read (rgb8, bgr8, rgba8, bgra8, mono8, yuyv or yuv422)");
}

cv::Mat DepthFromRosImage(const RosImage& image, double metres_per_unit, const std::string& where) {
  const bool millimetres = image.encoding == "16UC1" || image.encoding == "mono16";
  const bool metres = image.encoding == "32FC1";
  if (!millimetres && !metres) {
    throw InputError(where + ": depth encoding " + Quoted(image.encoding) +
                     " is not read (16UC1 or mono16 in millimetres, 32FC1 in metres)");
  }
  if (image.big_endian) throw InputError(where + ": big-endian depth is not read");
  const int type = millimetres ? CV_16UC1 : CV_32FC1;
  const size_t row = static_cast<size_t>(image.width) * CV_ELEM_SIZE(type);
  if (image.step < row || image.size / image.step < image.height) {
    throw InputError(where + ": a " + image.encoding + " image whose data is shorter than " +
                     std::to_string(image.height) + " rows of " + std::to_string(row) + " bytes");
  }
  // The data need not be aligned: copy it row by row into an aligned image first.
  cv::Mat raw(static_cast<int>(image.height), static_cast<int>(image.width), type);
  for (int v = 0; v < raw.rows; ++v) {
    std::memcpy(raw.ptr(v), image.data + static_cast<size_t>(v) * image.step, row);
  }
  cv::Mat depth_m;
  if (millimetres) {
    raw.convertTo(depth_m, CV_32F, metres_per_unit);
    return depth_m;
  }
  depth_m = raw;
  depth_m.forEach<float>([](float& z, const int*) {
    if (!std::isfinite(z) || z < 0.0f) z = 0.0f;
  });
  return depth_m;
}

cv::Mat ColorFromRosCompressed(const RosCompressedImage& image, const std::string& where) {
  const std::vector<unsigned char> bytes(image.data, image.data + image.size);
  cv::Mat decoded;
  if (image.size >= 3 && image.data[0] == 0xFF && image.data[1] == 0xD8) {
    decoded = DecodeJpeg(where, bytes, kMaxSide);
  } else if (image.size >= 8 && std::memcmp(image.data, "\x89PNG", 4) == 0) {
    decoded = DecodePng(where, bytes);
  } else {
    throw InputError(where + ": compressed colour " + Quoted(image.format) +
                     " is neither JPEG nor PNG");
  }
  if (decoded.depth() != CV_8U) decoded.convertTo(decoded, CV_8U, 1.0 / 257.0);
  if (decoded.channels() == 1) cv::cvtColor(decoded, decoded, cv::COLOR_GRAY2BGR);
  if (decoded.channels() == 4) cv::cvtColor(decoded, decoded, cv::COLOR_BGRA2BGR);
  return decoded;
}

namespace {

// compressed_depth_image_transport's 16-bit values after its 12-byte ConfigHeader: a PNG, or
// (rvl) the image's int32 columns and rows, then RVL.
cv::Mat CompressedDepthValues(const RosCompressedImage& image, const std::string& where) {
  constexpr size_t kConfigHeader = 12;
  const bool rvl = image.format.find("compressedDepth rvl") != std::string::npos;
  const bool png = !rvl && image.format.find("compressedDepth") != std::string::npos;
  if (!png && !rvl) {
    throw InputError(where + ": compressed depth " + Quoted(image.format) +
                     " is not read (compressedDepth png or rvl)");
  }
  if (rvl) {
    if (image.size < kConfigHeader + 8) {
      throw InputError(where + ": compressedDepth rvl data without its header and size");
    }
    const std::uint32_t cols = Le32(image.data + kConfigHeader);
    const std::uint32_t rows = Le32(image.data + kConfigHeader + 4);
    constexpr std::uint64_t kMaxPixels = 4096ULL * 4096ULL;  // a few bytes of RVL can claim more
    if (cols == 0 || rows == 0 || static_cast<std::uint64_t>(cols) * rows > kMaxPixels) {
      throw InputError(where + ": compressedDepth rvl image of " + std::to_string(cols) + "x" +
                       std::to_string(rows) + " pixels");
    }
    cv::Mat raw(static_cast<int>(rows), static_cast<int>(cols), CV_16UC1);
    if (!DecodeRvl(image.data + kConfigHeader + 8, image.size - kConfigHeader - 8,
                   raw.ptr<std::uint16_t>(), raw.total())) {
      throw InputError(where + ": compressedDepth rvl data damaged (it does not decode to " +
                       std::to_string(cols) + "x" + std::to_string(rows) + " pixels)");
    }
    return raw;
  }
  if (image.size < kConfigHeader + 8 ||
      std::memcmp(image.data + kConfigHeader, "\x89PNG", 4) != 0) {
    throw InputError(where + ": compressedDepth data without its 12-byte header and PNG");
  }
  const std::vector<unsigned char> bytes(image.data + kConfigHeader, image.data + image.size);
  cv::Mat raw = DecodePng(where, bytes);
  if (raw.type() != CV_16UC1) throw InputError(where + ": compressedDepth PNG is not 16-bit gray");
  return raw;
}

}  // namespace

cv::Mat DepthFromRosCompressed(const RosCompressedImage& image, double metres_per_unit,
                               const std::string& where) {
  // The ConfigHeader: int32 format, float depthParam[2] (the inverse depth's quantization).
  const cv::Mat raw = CompressedDepthValues(image, where);
  cv::Mat depth_m;
  if (image.format.rfind("32FC1", 0) == 0) {
    // Inverse depth, quantized: z = a / (v - b), 0 = no reading.
    float a = 0.0f, b = 0.0f;
    std::memcpy(&a, image.data + 4, sizeof(a));
    std::memcpy(&b, image.data + 8, sizeof(b));
    depth_m.create(raw.size(), CV_32FC1);
    for (int v = 0; v < raw.rows; ++v) {
      for (int u = 0; u < raw.cols; ++u) {
        const std::uint16_t q = raw.at<std::uint16_t>(v, u);
        const float z = q == 0 ? 0.0f : a / (static_cast<float>(q) - b);
        depth_m.at<float>(v, u) = std::isfinite(z) && z > 0.0f ? z : 0.0f;
      }
    }
    return depth_m;
  }
  raw.convertTo(depth_m, CV_32F, metres_per_unit);
  return depth_m;
}

}  // namespace stillmap
