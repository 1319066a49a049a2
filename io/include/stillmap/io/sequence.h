// A recorded RGB-D sequence in the TUM layout: rgb.txt, depth.txt, optional groundtruth.txt and
// camera.yaml, images under the folder.
#pragma once

#include <array>
#include <map>
#include <memory>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "stillmap/io/camera.h"
#include "stillmap/io/option_fields.h"
#include "stillmap/io/trajectory.h"
#include "stillmap/io/transform_tree.h"

namespace stillmap {

// Camera settings given on the command line or in the config, applied over camera.yaml (or over
// the preset, when one is named).
struct CameraOverrides {
  std::string preset;                               // tum1|tum2|tum3|bonn|ros_default, or empty
  std::optional<int> width, height;                 // [px]
  std::optional<double> fx, fy, cx, cy;             // [px]
  std::optional<std::array<double, 5>> distortion;  // k1 k2 p1 p2 k3
  std::optional<double> depth_factor;

  // Every field under its configuration key (io/option_fields.h).
  template <typename Self, typename Visitor>
  static void VisitFields(Self& self, Visitor& visit) {
    visit("preset", self.preset,
          "tum1|tum2|tum3|bonn|ros_default; used instead of the sequence's camera.yaml");
    visit("width", self.width, "image width [px]");
    visit("height", self.height, "image height [px]");
    visit("fx", self.fx, "focal length x [px]");
    visit("fy", self.fy, "focal length y [px]");
    visit("cx", self.cx, "principal point x [px]");
    visit("cy", self.cy, "principal point y [px]");
    visit("distortion", self.distortion, "k1,k2,p1,p2,k3 (OpenCV radial-tangential)");
    visit("depth_factor", self.depth_factor, "depth PNG value per metre");
  }
};

// The sequence's camera: the named preset, else SEQUENCE_DIR/camera.yaml, else the camera keys
// (fx, fy, cx, cy at least), with any override applied last. Throws InputError saying how to name
// the camera when none of these exists.
Camera ResolveCamera(const std::string& sequence_dir, const CameraOverrides& overrides);

// The sequence's name for captions: the folder's last path component ("bonn_crowd_a" for
// "../shared/data/bonn_crowd_a/").
std::string SequenceName(const std::string& sequence_dir);

struct SequenceOptions {
  double max_pair_time_difference = 0.02;
  double max_groundtruth_gap = 0.1;
  // A ground-truth trajectory (TUM format) instead of the folder's groundtruth.txt; a bag has
  // none of its own.
  std::string groundtruth;
  // A recorded bag's topics (--topic KIND=NAME); empty: chosen by type, encoding and name.
  std::string color_topic, depth_topic, camera_info_topic;

  // Every field under its configuration key (io/option_fields.h).
  template <typename Self, typename Visitor>
  static void VisitFields(Self& self, Visitor& visit) {
    visit("max_pair_time_difference", self.max_pair_time_difference,
          "color/depth association window [s] (TUM associate.py: 0.02)");
    visit("max_groundtruth_gap", self.max_groundtruth_gap,
          "widest ground-truth gap a pose is interpolated across [s]");
    visit("groundtruth", self.groundtruth,
          "ground-truth trajectory file (TUM format) instead of groundtruth.txt (--groundtruth)");
    visit("color_topic", self.color_topic, "a bag's colour topic (empty: chosen by itself)");
    visit("depth_topic", self.depth_topic, "a bag's depth topic (empty: chosen by itself)");
    visit("camera_info_topic", self.camera_info_topic,
          "a bag's camera info topic (empty: the one beside the colour topic)");
  }
};

// One color/depth pair of the sequence.
struct FrameEntry {
  double time = 0.0;        // color timestamp [s]; the frame's time
  double depth_time = 0.0;  // depth timestamp [s]
  std::string color_path;   // full path
  std::string depth_path;   // full path
};

// A decoded frame, depth registered to color.
struct Frame {
  size_t index = 0;   // position in Sequence::frames()
  double time = 0.0;  // [s]
  cv::Mat color;      // CV_8UC3, BGR
  cv::Mat depth_m;    // CV_32FC1 [m], 0 = no reading
};

class BagFrames;

// What a bag recorded of where things were (issue 48): /tf, /tf_static and every
// nav_msgs/Odometry topic, each message's transforms in bag order.
struct RecordedPoses {
  std::vector<TransformSample> tf, tf_static;
  std::map<std::string, std::vector<TransformSample>> odometry;  // by topic
  std::string color_frame;  // the colour images' header frame_id (their first message's)
  // Messages of those topics that do not decode, by topic.
  std::map<std::string, size_t> undecoded;
};

// True when `path` is a recorded bag: a file whose bytes start like one, or a ROS 2 bag folder
// (bag_reader.h).
bool IsBag(const std::string& path);

// A bag's topics (name, type, encoding or format, count, rate), then the colour, depth and
// camera-info topics a build would use, or why it would refuse. Throws InputError for a file
// that is not a bag.
std::string DescribeBagTopics(const std::string& path, const SequenceOptions& options = {});

class Sequence {
 public:
  // A recorded bag (io/bag_reader.h): its colour, depth and camera-info topics (the options' or
  // chosen by type, encoding and name), paired by header stamp, the camera from its CameraInfo
  // with `overrides` over it. Throws InputError naming the bag for a missing or ambiguous
  // stream (listing the topics), depth not registered to colour, or no pair.
  static Sequence OpenBag(const std::string& path, const CameraOverrides& overrides,
                          const SequenceOptions& options = {});

  // Reads the lists and ground truth of a TUM-layout folder and pairs color with depth. Throws
  // InputError for a missing folder or list, a malformed line, or no pair within the window.
  static Sequence Open(const std::string& dir, const Camera& camera,
                       const SequenceOptions& options = {});

  // Decodes frame `index`; throws InputError for a missing, truncated or malformed image, or one
  // whose size differs from the camera's.
  Frame LoadFrame(size_t index) const;

  const std::string& dir() const { return dir_; }
  const Camera& camera() const { return camera_; }
  const SequenceOptions& options() const { return options_; }
  const std::vector<FrameEntry>& frames() const { return frames_; }
  size_t color_count() const { return color_count_; }  // lines in rgb.txt
  size_t depth_count() const { return depth_count_; }  // lines in depth.txt
  // The camera's ground-truth trajectory (groundtruth_body_from_camera applied), when the
  // sequence has groundtruth.txt.
  const std::optional<Trajectory>& groundtruth() const { return groundtruth_; }
  // Non-empty when groundtruth.txt is there but holds no poses (groundtruth() is then empty):
  // what to tell the user.
  const std::string& groundtruth_note() const { return groundtruth_note_; }
  // How the input was read: a bag's topics, a camera setting that overrode its CameraInfo.
  const std::vector<std::string>& notes() const { return notes_; }
  // What went wrong in reading it: a recording cut short ("truncated"), damaged parts skipped.
  const std::vector<std::string>& warnings() const { return warnings_; }
  bool is_bag() const { return bag_ != nullptr; }
  // A bag's /tf, /tf_static and odometry (null for a folder).
  const RecordedPoses* recorded_poses() const { return recorded_poses_.get(); }

 private:
  // Reads the ground truth at `path` (TUM format) with the camera's body transform.
  void ReadGroundtruth(const std::string& path);
  void LoadBagFrame(size_t index, Frame* frame) const;

  std::string dir_;
  Camera camera_;
  SequenceOptions options_;
  std::vector<FrameEntry> frames_;
  size_t color_count_ = 0;
  size_t depth_count_ = 0;
  std::optional<Trajectory> groundtruth_;
  std::string groundtruth_note_;
  std::vector<std::string> notes_, warnings_;
  std::shared_ptr<const BagFrames> bag_;  // a bag's frames (null for a folder)
  std::shared_ptr<const RecordedPoses> recorded_poses_;
};

}  // namespace stillmap
