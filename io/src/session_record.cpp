#include "stillmap/io/session_record.h"

#include <fmt/format.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <functional>
#include <limits>
#include <nlohmann/json.hpp>
#include <type_traits>

#include "jpeg_decoder.h"
#include "png_decoder.h"
#include "stillmap/io/error.h"
#include "stillmap/io/input_files.h"

namespace stillmap {
namespace {

using nlohmann::json;

constexpr char kMagic[16] = {'s', 't', 'i', 'l', 'l', 'm', 'a', 'p',
                             '-', 's', 'e', 's', 's', 'i', 'o', 'n'};
constexpr std::uint64_t kPreambleBytes = sizeof(kMagic) + 4 + 8;
constexpr std::uint64_t kMaxHeaderBytes = 256ull << 20;  // far above 10^5 keyframes' metadata
// One feature on file: u v x y depth (float32), octave (uint8), descriptor (32 bytes).
constexpr size_t kFeatureBytes = 5 * 4 + 1 + 32;

// Little-endian stores and loads (the machines stillmap runs on are little-endian, but the file
// says so and does not depend on it).
template <typename T>
void Put(std::vector<unsigned char>* out, T value) {
  unsigned char bytes[sizeof(T)];
  std::memcpy(bytes, &value, sizeof(T));
  out->insert(out->end(), bytes, bytes + sizeof(T));
}
template <typename T>
T Get(const unsigned char* in) {
  T value;
  std::memcpy(&value, in, sizeof(T));
  return value;
}

json PoseJson(const Eigen::Isometry3d& pose) {
  const Eigen::Quaterniond q(pose.linear());
  const Eigen::Vector3d t = pose.translation();
  return json::array({t.x(), t.y(), t.z(), q.x(), q.y(), q.z(), q.w()});
}

json MatrixJson(const Eigen::Isometry3d& transform) {
  json rows = json::array();
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) rows.push_back(transform.matrix()(r, c));
  }
  return rows;
}

json CameraJson(const Camera& camera) {
  json out = {{"width", camera.width},
              {"height", camera.height},
              {"fx", camera.fx},
              {"fy", camera.fy},
              {"cx", camera.cx},
              {"cy", camera.cy},
              {"distortion", camera.distortion},
              {"rational", camera.rational},
              {"depth_factor", camera.depth_factor}};
  if (camera.groundtruth_body_from_camera) {
    out["groundtruth_body_from_camera"] = MatrixJson(*camera.groundtruth_body_from_camera);
  }
  return out;
}

json HeaderJson(const SessionRecord& record, const std::vector<SessionBlockSizes>& rows) {
  const SessionMapFrame& frame = record.map_frame;
  json keyframes = json::array();
  for (const SessionBlockSizes& row : rows) {
    const SessionKeyframe& keyframe = *row.keyframe;
    keyframes.push_back({{"id", keyframe.id},
                         {"time", keyframe.time},
                         {"map_from_camera", PoseJson(keyframe.map_from_camera)},
                         {"features", row.features},
                         {"depth_png_bytes", row.depth_png},
                         {"color_jpeg_bytes", row.color_jpeg}});
  }
  json header = {{"camera", CameraJson(record.camera)},
                 {"map_frame",
                  {{"name", frame.name},
                   {"description", frame.description},
                   {"floor_up", {frame.floor_up.x(), frame.floor_up.y(), frame.floor_up.z()}},
                   {"floor_offset", frame.floor_offset},
                   {"floor_found", frame.floor_found},
                   {"floor_source", frame.floor_source},
                   {"map_from_floor", MatrixJson(frame.map_from_floor)}}},
                 {"depth_unit_m", record.depth_unit_m},
                 {"sequence", record.sequence},
                 {"stillmap_version", record.stillmap_version},
                 {"keyframes", keyframes}};
  if (!record.poses.empty()) header["poses"] = record.poses;
  return header;
}

// The header's values, each checked: a missing or mistyped key names the key.
class HeaderReader {
 public:
  explicit HeaderReader(std::string path) : path_(std::move(path)) {}
  const std::string& path() const { return path_; }

  template <typename T>
  T Value(const json& object, const char* key) const {
    const auto it = object.find(key);
    if (it == object.end()) Fail(fmt::format("the header has no '{}'", key));
    if constexpr (std::is_integral_v<T> && !std::is_same_v<T, bool>) {
      // nlohmann converts a float or an out-of-range integer with a plain cast.
      const bool fits = it->is_number_unsigned()
                            ? it->template get<std::uint64_t>() <=
                                  static_cast<std::uint64_t>(std::numeric_limits<T>::max())
                            : it->is_number_integer() &&
                                  it->template get<std::int64_t>() >=
                                      static_cast<std::int64_t>(std::numeric_limits<T>::min()) &&
                                  (std::is_unsigned_v<T> ||
                                   it->template get<std::int64_t>() <=
                                       static_cast<std::int64_t>(std::numeric_limits<T>::max()));
      if (!fits) Fail(fmt::format("the header's '{}' is not an integer in range", key));
    }
    try {
      return it->get<T>();
    } catch (const json::exception&) {
      Fail(fmt::format("the header's '{}' is not of the expected type", key));
    }
  }

  double Finite(const json& object, const char* key) const {
    const auto value = Value<double>(object, key);
    if (!std::isfinite(value)) Fail(fmt::format("the header's '{}' is not finite", key));
    return value;
  }

  Eigen::Isometry3d Pose(const json& object, const char* key) const {
    const auto v = Value<std::vector<double>>(object, key);
    Eigen::Quaterniond q(v.size() == 7 ? v[6] : 0.0, v.size() == 7 ? v[3] : 0.0,
                         v.size() == 7 ? v[4] : 0.0, v.size() == 7 ? v[5] : 0.0);
    bool finite = v.size() == 7;
    for (const double x : v) finite = finite && std::isfinite(x);
    if (!finite || std::abs(q.norm() - 1.0) > 1e-3) {
      Fail(fmt::format("'{}' is not a pose (tx ty tz qx qy qz qw with a unit quaternion)", key));
    }
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.linear() = q.normalized().toRotationMatrix();
    pose.translation() = Eigen::Vector3d(v[0], v[1], v[2]);
    return pose;
  }

  // `tolerance`: how far from orthonormal its rotation may be (the camera file's
  // groundtruth_body_from_camera is printed with few digits).
  Eigen::Isometry3d Matrix(const json& object, const char* key, double tolerance = 1e-6) const {
    const auto v = Value<std::vector<double>>(object, key);
    if (v.size() != 16) Fail(fmt::format("'{}' is not a 4x4 matrix", key));
    Eigen::Isometry3d transform = Eigen::Isometry3d::Identity();
    for (int i = 0; i < 12; ++i) transform.matrix()(i / 4, i % 4) = v[static_cast<size_t>(i)];
    const Eigen::Matrix3d r = transform.linear();
    if (!transform.matrix().allFinite() ||
        (r * r.transpose() - Eigen::Matrix3d::Identity()).norm() > tolerance) {
      Fail(fmt::format("'{}' is not a rigid transform", key));
    }
    return transform;
  }

  [[noreturn]] void Fail(const std::string& what) const {
    throw InputError(path_ + ": damaged session record: " + what +
                     "; build the session again (stillmap build)");
  }

 private:
  std::string path_;
};

Camera ParseCamera(const json& j, const HeaderReader& read, const std::string& path) {
  Camera camera;
  camera.width = read.Value<int>(j, "width");
  camera.height = read.Value<int>(j, "height");
  camera.fx = read.Finite(j, "fx");
  camera.fy = read.Finite(j, "fy");
  camera.cx = read.Finite(j, "cx");
  camera.cy = read.Finite(j, "cy");
  camera.distortion = read.Value<std::array<double, 5>>(j, "distortion");
  camera.rational = read.Value<std::array<double, 3>>(j, "rational");
  camera.depth_factor = read.Finite(j, "depth_factor");
  if (j.contains("groundtruth_body_from_camera")) {
    camera.groundtruth_body_from_camera =
        read.Matrix(j, "groundtruth_body_from_camera", 1e-3);  // as camera.yaml
  }
  camera.Validate(path + " (the session's camera)");
  return camera;
}

SessionMapFrame ParseMapFrame(const json& j, const HeaderReader& read) {
  SessionMapFrame frame;
  frame.name = read.Value<std::string>(j, "name");
  frame.description = read.Value<std::string>(j, "description");
  const auto up = read.Value<std::array<double, 3>>(j, "floor_up");
  frame.floor_up = Eigen::Vector3d(up[0], up[1], up[2]);
  if (!frame.floor_up.allFinite() || std::abs(frame.floor_up.norm() - 1.0) > 1e-6) {
    read.Fail("'floor_up' is not a unit vector");
  }
  frame.floor_offset = read.Finite(j, "floor_offset");
  frame.floor_found = read.Value<bool>(j, "floor_found");
  frame.floor_source = read.Value<std::string>(j, "floor_source");
  frame.map_from_floor = read.Matrix(j, "map_from_floor");
  return frame;
}

// The header's record; the features are read from the file by `read_block` (offset, size).
template <typename ReadBlock>
SessionRecord ParseRecord(const json& header, std::uint64_t offset, std::uint64_t file_size,
                          const HeaderReader& read, ReadBlock&& read_block) {
  SessionRecord record;
  record.camera = ParseCamera(read.Value<json>(header, "camera"), read, read.path());
  record.map_frame = ParseMapFrame(read.Value<json>(header, "map_frame"), read);
  record.depth_unit_m = read.Finite(header, "depth_unit_m");
  if (!(record.depth_unit_m > 0.0)) read.Fail("'depth_unit_m' is not positive");
  record.sequence = read.Value<std::string>(header, "sequence");
  record.stillmap_version = read.Value<std::string>(header, "stillmap_version");
  if (header.contains("poses")) record.poses = read.Value<std::string>(header, "poses");
  const json keyframes = read.Value<json>(header, "keyframes");
  if (!keyframes.is_array()) read.Fail("'keyframes' is not a list");
  auto block = [&](const json& entry, const char* key, std::uint64_t* at, std::uint64_t* size) {
    *size = read.Value<std::uint64_t>(entry, key);
    if (*size > file_size - offset)
      read.Fail(fmt::format("a block ('{}') runs past the end of the file", key));
    *at = offset;
    offset += *size;
  };
  for (const json& entry : keyframes) {
    SessionKeyframe keyframe;
    keyframe.id = read.Value<int>(entry, "id");
    keyframe.time = read.Finite(entry, "time");
    keyframe.map_from_camera = read.Pose(entry, "map_from_camera");
    if (!record.keyframes.empty() && keyframe.time <= record.keyframes.back().time) {
      read.Fail(fmt::format("keyframe {} is not later than the one before it", keyframe.id));
    }
    const auto count = read.Value<std::uint64_t>(entry, "features");
    if (count > (file_size - offset) / kFeatureBytes)
      read.Fail("a feature block runs past the end of the file");
    const std::uint64_t feature_bytes = count * kFeatureBytes;
    keyframe.features = ParseSessionFeatures(read_block(offset, feature_bytes));
    for (const SessionFeature& f : keyframe.features) {
      if (!std::isfinite(f.u) || !std::isfinite(f.v) || !std::isfinite(f.x) ||
          !std::isfinite(f.y) || !std::isfinite(f.depth_m)) {
        read.Fail(fmt::format("keyframe {} holds a feature whose position or depth is not finite",
                              keyframe.id));
      }
    }
    offset += feature_bytes;
    block(entry, "depth_png_bytes", &keyframe.depth_offset, &keyframe.depth_size);
    block(entry, "color_jpeg_bytes", &keyframe.color_offset, &keyframe.color_size);
    record.keyframes.push_back(std::move(keyframe));
  }
  if (offset != file_size) read.Fail("it holds more bytes than its header describes");
  return record;
}

}  // namespace

void AppendSessionFeatures(const std::vector<SessionFeature>& features,
                           std::vector<unsigned char>* out) {
  for (const SessionFeature& f : features) {
    for (const float value : {f.u, f.v, f.x, f.y, f.depth_m}) Put(out, value);
    out->push_back(f.octave);
    out->insert(out->end(), f.descriptor.begin(), f.descriptor.end());
  }
}

std::vector<SessionFeature> ParseSessionFeatures(const std::vector<unsigned char>& bytes) {
  std::vector<SessionFeature> features(bytes.size() / kFeatureBytes);
  const unsigned char* at = bytes.data();
  for (SessionFeature& f : features) {
    float* fields[] = {&f.u, &f.v, &f.x, &f.y, &f.depth_m};
    for (float* field : fields) {
      *field = Get<float>(at);
      at += 4;
    }
    f.octave = *at++;
    std::memcpy(f.descriptor.data(), at, f.descriptor.size());
    at += f.descriptor.size();
  }
  return features;
}

void WriteSessionRecord(const std::string& path, const SessionRecord& record,
                        const std::vector<SessionBlockSizes>& rows,
                        const std::function<SessionBlockBytes(size_t index)>& load) {
  const std::string header = HeaderJson(record, rows).dump();
  std::vector<unsigned char> preamble(kMagic, kMagic + sizeof(kMagic));
  Put(&preamble, SessionRecord::kVersion);
  Put(&preamble, static_cast<std::uint64_t>(header.size()));
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  auto write = [&out](const std::vector<unsigned char>& bytes) {
    out.write(reinterpret_cast<const char*>(bytes.data()),
              static_cast<std::streamsize>(bytes.size()));
  };
  write(preamble);
  out.write(header.data(), static_cast<std::streamsize>(header.size()));
  for (size_t index = 0; index < rows.size(); ++index) {
    const SessionBlockBytes blocks = load(index);
    if (blocks.features.size() != rows[index].features * kFeatureBytes ||
        blocks.depth_png.size() != rows[index].depth_png ||
        blocks.color_jpeg.size() != rows[index].color_jpeg) {
      throw std::logic_error("WriteSessionRecord: a keyframe's blocks differ from its sizes");
    }
    write(blocks.features);
    write(blocks.depth_png);
    write(blocks.color_jpeg);
  }
  if (!out.flush()) throw std::runtime_error(WriteFailure(path, "the session record"));
}

void WriteSessionRecord(const std::string& path, const SessionRecord& record,
                        const std::vector<SessionKeyframeBlocks>& keyframes) {
  std::vector<SessionBlockSizes> rows;
  rows.reserve(keyframes.size());
  for (const SessionKeyframeBlocks& block : keyframes) {
    rows.push_back({&block.keyframe, block.keyframe.features.size(), block.depth_png.size(),
                    block.color_jpeg.size()});
  }
  WriteSessionRecord(path, record, rows, [&keyframes](size_t index) {
    const SessionKeyframeBlocks& block = keyframes[index];
    SessionBlockBytes bytes{{}, block.depth_png, block.color_jpeg};
    AppendSessionFeatures(block.keyframe.features, &bytes.features);
    return bytes;
  });
}

SessionRecordReader::SessionRecordReader(const std::string& path) : path_(path) {
  CheckInputFile(path, "session record");  // a FIFO would block the read, a folder fail it
  file_.open(path, std::ios::binary);
  if (!file_) {
    throw InputError(path + ": cannot open the session record (" + std::strerror(errno) + ")");
  }
  file_.seekg(0, std::ios::end);
  file_size_ = static_cast<std::uint64_t>(file_.tellg());
  const HeaderReader read(path);
  const std::vector<unsigned char> start = ReadBlock(0, std::min<std::uint64_t>(file_size_, 16));
  if (start.empty() || std::memcmp(start.data(), kMagic, start.size()) != 0) {
    throw InputError(path +
                     ": not a stillmap session record (its first bytes are not "
                     "'stillmap-session')");
  }
  if (file_size_ < kPreambleBytes) read.Fail("shorter than its preamble");
  const std::vector<unsigned char> preamble = ReadBlock(0, kPreambleBytes);
  const auto version = Get<std::uint32_t>(preamble.data() + sizeof(kMagic));
  if (version != SessionRecord::kVersion) {
    throw InputError(fmt::format(
        "{}: session record format version {}, but this stillmap reads version {}; build the "
        "session again with this stillmap",
        path, version, SessionRecord::kVersion));
  }
  const auto header_size = Get<std::uint64_t>(preamble.data() + sizeof(kMagic) + 4);
  if (header_size > kMaxHeaderBytes || header_size > file_size_ - kPreambleBytes) {
    read.Fail("its header's size runs past the end of the file");
  }
  const std::vector<unsigned char> header_bytes = ReadBlock(kPreambleBytes, header_size);
  const json header = json::parse(header_bytes.begin(), header_bytes.end(), nullptr, false);
  if (header.is_discarded() || !header.is_object()) read.Fail("its header is not JSON");
  record_ =
      ParseRecord(header, kPreambleBytes + header_size, file_size_, read,
                  [this](std::uint64_t at, std::uint64_t size) { return ReadBlock(at, size); });
}
std::vector<unsigned char> SessionRecordReader::ReadBlock(std::uint64_t offset,
                                                          std::uint64_t size) {
  std::vector<unsigned char> bytes(size);
  file_.clear();
  file_.seekg(static_cast<std::streamoff>(offset));
  file_.read(reinterpret_cast<char*>(bytes.data()), static_cast<std::streamsize>(size));
  if (!file_) throw InputError(path_ + ": could not read the session record (cut short?)");
  return bytes;
}

SessionImages SessionRecordReader::ReadImages(size_t index) {
  const SessionKeyframe& keyframe = record_.keyframes.at(index);
  const Camera& camera = record_.camera;
  auto decode = [&](std::uint64_t offset, std::uint64_t size, bool jpeg, int type,
                    const char* what) {
    // stillmap's own decoders: damage is said in the user's words, never libpng's or libjpeg's.
    const std::string where = fmt::format("{}: keyframe {}'s {}", path_, keyframe.id, what);
    const std::vector<unsigned char> bytes = ReadBlock(offset, size);
    cv::Mat image =
        jpeg ? DecodeJpeg(where, bytes, Camera::kMaxImageSide) : DecodePng(where, bytes);
    if (image.type() != type || image.cols != camera.width || image.rows != camera.height) {
      HeaderReader(path_).Fail(fmt::format("keyframe {}'s {} does not decode to a {}x{} image",
                                           keyframe.id, what, camera.width, camera.height));
    }
    return image;
  };
  SessionImages images;
  decode(keyframe.depth_offset, keyframe.depth_size, false, CV_16UC1, "depth")
      .convertTo(images.depth_m, CV_32F, record_.depth_unit_m);
  images.color = decode(keyframe.color_offset, keyframe.color_size, true, CV_8UC3, "colour");
  return images;
}

}  // namespace stillmap
