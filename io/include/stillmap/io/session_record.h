// The session record: what `stillmap merge` needs of a build, kept beside its map as
// OUT_DIR/session.bin. One file, written by WriteSessionRecord and read by SessionRecordReader
// (side by side in session_record.cpp; the layout is in docs/session-record.md):
//
//   magic "stillmap-session" (16 bytes), format version (uint32), size of the header (uint64),
//   the header (JSON: camera, map frame, depth unit, and per keyframe its id, time, final pose
//   and the sizes of its blocks), then per keyframe, in the header's order, its blocks: the
//   features (fixed-size binary records), the depth without what moves (16-bit PNG) and the
//   colour (JPEG).
//
// Little-endian throughout. Every size is checked against the file before it is used, so a file
// cut short or damaged is an InputError naming it, never a crash or a partial session.
#pragma once

#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <fstream>
#include <functional>
#include <memory>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "stillmap/io/camera.h"

namespace stillmap {

// One ORB feature of a keyframe, as the tracker extracted it.
struct SessionFeature {
  float u = 0.0f, v = 0.0f;  // pixel position as detected (distorted) [px]
  float x = 0.0f, y = 0.0f;  // undistorted normalized coordinates (x/z, y/z)
  float depth_m = 0.0f;      // depth at the keypoint [m], 0 = none
  std::uint8_t octave = 0;   // ORB pyramid level
  std::array<std::uint8_t, 32> descriptor{};
};

// A keyframe fused into the session's map.
struct SessionKeyframe {
  int id = 0;         // the build's keyframe id (increasing with time)
  double time = 0.0;  // [s], the recording's clock
  Eigen::Isometry3d map_from_camera = Eigen::Isometry3d::Identity();  // final, in the map frame
  std::vector<SessionFeature> features;
  // Where its blocks lie in the file (SessionRecordReader::ReadImages).
  std::uint64_t depth_offset = 0, depth_size = 0;
  std::uint64_t color_offset = 0, color_size = 0;
};

// A keyframe's images: what the build fused, in compact form.
struct SessionImages {
  cv::Mat depth_m;  // CV_32FC1 [m], corrected; 0 = no reading or masked as moving
  cv::Mat color;    // CV_8UC3 BGR
};

// The map frame of the session's outputs: the frame the keyframe poses are in.
struct SessionMapFrame {
  std::string name;                                     // floor | camera | groundtruth (map.frame)
  std::string description;                              // as in the outputs' headers
  Eigen::Vector3d floor_up = Eigen::Vector3d::UnitZ();  // the floor plane in the map frame:
  double floor_offset = 0.0;                            // height = floor_up . x + floor_offset
  bool floor_found = false;
  std::string floor_source;
  Eigen::Isometry3d map_from_floor = Eigen::Isometry3d::Identity();
};

// Everything but the images, which stay in the file until asked for.
struct SessionRecord {
  static constexpr std::uint32_t kVersion = 1;
  Camera camera;
  SessionMapFrame map_frame;
  double depth_unit_m = 0.0;  // the depth PNGs' step [m]
  std::string sequence;       // the recording the build read
  std::string stillmap_version;
  // Where the build's poses came from besides its own tracking ("tf:odom, the tracker's prior");
  // empty for a build that tracked alone (the key is then left out of the header).
  std::string poses;
  std::vector<SessionKeyframe> keyframes;  // in time order
};

// A keyframe as WriteSessionRecord takes it: its metadata and its blocks, already encoded.
struct SessionKeyframeBlocks {
  SessionKeyframe keyframe;              // offsets and sizes are filled in by the writer
  std::vector<unsigned char> depth_png;  // CV_16UC1 in depth_unit_m
  std::vector<unsigned char> color_jpeg;
};

// Writes the record to `path`. Throws std::runtime_error when it cannot be written.
void WriteSessionRecord(const std::string& path, const SessionRecord& record,
                        const std::vector<SessionKeyframeBlocks>& keyframes);

// A keyframe's row in the header: its metadata (features not read) and its blocks' sizes.
struct SessionBlockSizes {
  const SessionKeyframe* keyframe = nullptr;
  std::uint64_t features = 0;                   // how many
  std::uint64_t depth_png = 0, color_jpeg = 0;  // bytes
};
// A keyframe's blocks as the file holds them (features by AppendSessionFeatures).
struct SessionBlockBytes {
  std::vector<unsigned char> features, depth_png, color_jpeg;
};
// The same, with each keyframe's blocks asked for (`load`) only when they are written, so that
// they need not all be in memory at once. Throws std::logic_error when a block's size differs
// from its row's.
void WriteSessionRecord(const std::string& path, const SessionRecord& record,
                        const std::vector<SessionBlockSizes>& rows,
                        const std::function<SessionBlockBytes(size_t index)>& load);

// Features in the file's form (fixed-size little-endian records), appended to `out`, and back.
void AppendSessionFeatures(const std::vector<SessionFeature>& features,
                           std::vector<unsigned char>* out);
std::vector<SessionFeature> ParseSessionFeatures(const std::vector<unsigned char>& bytes);

// Reads a session record: the header and features at once, a keyframe's images on request.
class SessionRecordReader {
 public:
  // Throws InputError naming `path` when it is missing, not a session record, of another format
  // version, or damaged (a size beyond the file, a header that does not parse).
  explicit SessionRecordReader(const std::string& path);

  const SessionRecord& record() const { return record_; }
  const std::string& path() const { return path_; }

  // Decodes the images of keyframe `index` (of record().keyframes). Throws InputError when a
  // block does not decode or does not fit the camera.
  SessionImages ReadImages(size_t index);

 private:
  std::vector<unsigned char> ReadBlock(std::uint64_t offset, std::uint64_t size);

  std::string path_;
  std::ifstream file_;
  std::uint64_t file_size_ = 0;
  SessionRecord record_;
};

}  // namespace stillmap
