// Camera poses given from outside the build (issue 48): a TUM-format trajectory file, a bag's
// tf tree (/tf and /tf_static), or a bag's nav_msgs/Odometry joined to the camera through
// /tf_static. Each is read into one transform tree (transform_tree.h) whose chain, from the
// poses' world to the camera, is looked up at every frame's stamp, as tf2 would.
#pragma once

#include <Eigen/Geometry>
#include <array>
#include <optional>
#include <string>
#include <vector>

#include "stillmap/io/sequence.h"
#include "stillmap/io/transform_tree.h"

namespace stillmap {

// How given poses are read and used (poses.*).
struct GivenPoseOptions {
  // map: the poses as given, no visual tracking; prior: the tracker predicts each frame from the
  // poses' increment and falls back on them where vision fails.
  std::string use = "map";
  // A trajectory file's body in the camera's place: the camera's pose in the body frame,
  // row-major 4x4 (identity: the file holds the camera's poses).
  std::array<double, 16> body_from_camera = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
  // A pose is interpolated between two samples at most this far apart [s].
  double max_gap_s = 0.2;
  // With poses.use=map a frame is a keyframe when the camera moved or turned this much since the
  // last one (0 and 0: every frame fused, as with ground-truth poses) [m], [deg]. Keyframes are
  // fused as tracked ones are (map re-check, masked share, revisit cells). 0.05 m / 5 deg was
  // chosen on five synthetic scenarios' ghosts and completeness and bonn_crowd_a's speed
  // (docs/figures.md, "Given poses through the keyframe fuser").
  double keyframe_distance_m = 0.05;
  double keyframe_angle_deg = 5.0;

  // Every field under its configuration key (io/option_fields.h).
  template <typename Self, typename Visitor>
  static void VisitFields(Self& self, Visitor& visit) {
    visit("use", self.use,
          "map (the given poses as they are, no visual tracking) or prior (the tracker predicts "
          "from their motion and falls back on them where vision fails)");
    visit("body_from_camera", self.body_from_camera,
          "the camera's pose in the body frame of a trajectory file (16 numbers, row-major 4x4)");
    visit("max_gap_s", self.max_gap_s,
          "widest gap between two given poses that a frame's pose is interpolated across [s]");
    visit("keyframe_distance_m", self.keyframe_distance_m,
          "poses.use=map: a frame is a keyframe when the camera moved this far since the last "
          "one [m] (0 with keyframe_angle_deg 0: every frame fused)");
    visit("keyframe_angle_deg", self.keyframe_angle_deg,
          "poses.use=map: ... or turned this far [deg]");
  }
  // Throws InputError naming the key for a value out of range.
  void Validate() const;
  Eigen::Isometry3d BodyFromCamera() const;
};

// What run.poses names, besides tracking and groundtruth.
struct GivenPoseSource {
  enum class Kind { kFile, kTf, kOdom } kind = Kind::kFile;
  std::string value;  // the file, the tf frame (tf:FRAME) or the odometry topic (odom:TOPIC)
  std::string text;   // as given
};

// The source `text` names: "tf:FRAME", "odom:TOPIC" or a trajectory file; nothing for
// "tracking" and "groundtruth". Throws InputError (naming `key`) for "tf:" or "odom:" with
// nothing after it.
std::optional<GivenPoseSource> ParseGivenPoseSource(const std::string& text,
                                                    const std::string& key);

class GivenPoses {
 public:
  // Reads the poses for `sequence`: the file, or the bag's transforms (tf and odom need a bag).
  // Throws InputError for a file that does not read, a sequence that is not a bag, a topic or
  // frame the bag does not hold (listing those it holds), frames in two trees (naming both), or
  // no message that decodes.
  static GivenPoses Open(const Sequence& sequence, const GivenPoseSource& source,
                         const GivenPoseOptions& options);

  // The camera's pose in the poses' world at `stamp`; nothing, with *miss (may be null) saying
  // why, outside the poses' span or across a gap wider than max_gap_s.
  std::optional<Eigen::Isometry3d> At(double stamp, LookupMiss* miss) const;

  const GivenPoseSource& source() const { return source_; }
  // The poses' world frame: the tf frame, the odometry's frame_id, or "the file's world".
  const std::string& world_frame() const { return world_; }
  // Where they come from, for the notes and the report: "tf:odom, odom -> base_link -> camera
  // (/tf, /tf_static)".
  const std::string& description() const { return description_; }
  // The stamps every sample chain covers [s].
  std::pair<double, double> span() const { return tree_.Span(world_, camera_); }
  // Messages or lines skipped (undecodable, not rigid, a second parent), one line per reason.
  const std::vector<std::string>& warnings() const { return warnings_; }

 private:
  GivenPoseSource source_;
  double max_gap_s_ = 0.0;
  TransformTree tree_;
  std::string world_, camera_;
  std::string description_;
  std::vector<std::string> warnings_;
};

}  // namespace stillmap
