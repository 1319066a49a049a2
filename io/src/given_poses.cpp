#include "stillmap/io/given_poses.h"

#include <fmt/format.h>

#include <cmath>
#include <map>

#include "stillmap/io/error.h"
#include "stillmap/io/option_names.h"
#include "stillmap/io/trajectory.h"

namespace stillmap {
namespace {

// Adds samples, counting those the tree refuses by reason.
void AddAll(const std::vector<TransformSample>& samples, bool is_static, const std::string& topic,
            TransformTree* tree, std::map<std::string, size_t>* refused) {
  for (const TransformSample& sample : samples) {
    std::string why;
    if (!tree->Add(sample, is_static, &why))
      ++(*refused)[fmt::format("{}: a transform that {}", topic, why)];
  }
}

// Messages skipped, as warnings naming the recording.
std::vector<std::string> SkippedWarnings(const std::string& path,
                                         const std::map<std::string, size_t>& undecoded,
                                         const std::map<std::string, size_t>& refused) {
  std::vector<std::string> warnings;
  warnings.reserve(undecoded.size() + refused.size());
  for (const auto& [topic, count] : undecoded) {
    warnings.push_back(
        fmt::format("{}: {} messages on {} do not decode and are left out", path, count, topic));
  }
  for (const auto& [reason, count] : refused) {
    warnings.push_back(fmt::format("{}: {} left out ({}x)", path, reason, count));
  }
  return warnings;
}

const RecordedPoses& RecordedOf(const Sequence& sequence, const GivenPoseSource& source) {
  if (sequence.recorded_poses() == nullptr) {
    throw InputError(fmt::format(
        "--poses {}: {} is a folder, not a recorded bag; tf: and odom: read a bag's /tf, "
        "/tf_static and odometry (give a folder's poses as a TUM trajectory file: --poses FILE)",
        source.text, sequence.dir()));
  }
  const RecordedPoses& recorded = *sequence.recorded_poses();
  if (TransformTree::FrameName(recorded.color_frame).empty()) {
    throw InputError(fmt::format(
        "--poses {}: {}: the colour images' header has no frame_id, so the camera cannot be "
        "found in the transform tree",
        source.text, sequence.dir()));
  }
  return recorded;
}

// The odometry topic the source names (with or without the leading '/').
const std::vector<TransformSample>& OdometryOf(const RecordedPoses& recorded,
                                               const GivenPoseSource& source,
                                               const std::string& path) {
  for (const auto& [topic, samples] : recorded.odometry) {
    if (TransformTree::FrameName(topic) == TransformTree::FrameName(source.value) &&
        !samples.empty()) {
      return samples;
    }
  }
  std::string topics;
  for (const auto& entry : recorded.odometry) topics += (topics.empty() ? "" : ", ") + entry.first;
  throw InputError(fmt::format(
      "--poses {}: {} holds no nav_msgs/Odometry message on {} that decodes; its odometry "
      "topics: {}",
      source.text, path, source.value, topics.empty() ? "none" : topics));
}

Eigen::Matrix4d RowMajorMatrix(const std::array<double, 16>& values) {
  Eigen::Matrix4d m;
  for (int i = 0; i < 16; ++i) m(i / 4, i % 4) = values[static_cast<size_t>(i)];
  return m;
}

}  // namespace

void GivenPoseOptions::Validate() const {
  if (use != "map" && use != "prior") {
    throw InputError(fmt::format("{} must be map or prior, not '{}'", OptionKey(*this, use), use));
  }
  if (!(max_gap_s > 0.0)) {
    throw InputError(fmt::format("{} must be positive", OptionKey(*this, max_gap_s)));
  }
  if (!(keyframe_distance_m >= 0.0) ||
      !(keyframe_angle_deg >= 0.0 && keyframe_angle_deg <= 180.0)) {
    throw InputError(fmt::format("{} must be >= 0 and {} in [0, 180]",
                                 OptionKey(*this, keyframe_distance_m),
                                 OptionKey(*this, keyframe_angle_deg)));
  }
  const Eigen::Matrix4d m = RowMajorMatrix(body_from_camera);
  const Eigen::Matrix3d r = m.topLeftCorner<3, 3>();
  if (!m.allFinite() || (r.transpose() * r - Eigen::Matrix3d::Identity()).norm() > 1e-3 ||
      r.determinant() < 0.0 || m.row(3) != Eigen::RowVector4d(0, 0, 0, 1)) {
    throw InputError(
        fmt::format("{} must be a rigid transform (a rotation, a translation, last row 0 0 0 1)",
                    OptionKey(*this, body_from_camera)));
  }
}

Eigen::Isometry3d GivenPoseOptions::BodyFromCamera() const {
  const Eigen::Matrix4d m = RowMajorMatrix(body_from_camera);
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() =
      Eigen::Quaterniond(Eigen::Matrix3d(m.topLeftCorner<3, 3>())).normalized().toRotationMatrix();
  pose.translation() = m.topRightCorner<3, 1>();
  return pose;
}

std::optional<GivenPoseSource> ParseGivenPoseSource(const std::string& text,
                                                    const std::string& key) {
  if (text == "tracking" || text == "groundtruth") return std::nullopt;
  GivenPoseSource source;
  source.text = text;
  source.value = text;
  for (const auto& [prefix, kind] :
       {std::pair{std::string("tf:"), GivenPoseSource::Kind::kTf},
        std::pair{std::string("odom:"), GivenPoseSource::Kind::kOdom}}) {
    if (text.rfind(prefix, 0) != 0) continue;
    source.kind = kind;
    source.value = text.substr(prefix.size());
    if (source.value.empty()) {
      throw InputError(fmt::format("{}={}: name the {} after '{}' ({}{})", key, text,
                                   kind == GivenPoseSource::Kind::kTf ? "frame" : "topic", prefix,
                                   prefix, kind == GivenPoseSource::Kind::kTf ? "odom" : "/odom"));
    }
  }
  if (text.empty()) {
    throw InputError(key +
                     " is empty: tracking, groundtruth, a trajectory file, tf:FRAME or "
                     "odom:TOPIC");
  }
  return source;
}

GivenPoses GivenPoses::Open(const Sequence& sequence, const GivenPoseSource& source,
                            const GivenPoseOptions& options) {
  GivenPoses poses;
  poses.source_ = source;
  poses.max_gap_s_ = options.max_gap_s;
  std::map<std::string, size_t> refused;
  std::map<std::string, size_t> undecoded;
  if (source.kind == GivenPoseSource::Kind::kFile) {
    const Trajectory trajectory = Trajectory::ReadTum(source.value);
    for (const StampedPose& pose : trajectory.poses()) {
      TransformSample sample{"world", "body", pose.time, pose.world_from_camera.translation(),
                             Eigen::Quaterniond(pose.world_from_camera.rotation())};
      AddAll({sample}, false, source.value, &poses.tree_, &refused);
    }
    const Eigen::Isometry3d body_from_camera = options.BodyFromCamera();
    AddAll({{"body", "camera", 0.0, body_from_camera.translation(),
             Eigen::Quaterniond(body_from_camera.rotation())}},
           true, OptionKey(options, options.body_from_camera), &poses.tree_, &refused);
    poses.world_ = "world";
    poses.camera_ = "camera";
    const bool body = !body_from_camera.isApprox(Eigen::Isometry3d::Identity(), 1e-12);
    poses.description_ = fmt::format(
        "{} (a TUM trajectory, {} poses{})", source.value, trajectory.size(),
        body ? ", the camera placed in its body by " + OptionKey(options, options.body_from_camera)
             : "");
  } else {
    const RecordedPoses& recorded = RecordedOf(sequence, source);
    undecoded = recorded.undecoded;
    AddAll(recorded.tf_static, true, "/tf_static", &poses.tree_, &refused);
    std::string from = "/tf, /tf_static";
    if (source.kind == GivenPoseSource::Kind::kTf) {
      AddAll(recorded.tf, false, "/tf", &poses.tree_, &refused);
      poses.world_ = TransformTree::FrameName(source.value);
    } else {
      const std::vector<TransformSample>& odometry = OdometryOf(recorded, source, sequence.dir());
      AddAll(odometry, false, source.value, &poses.tree_, &refused);
      poses.world_ = TransformTree::FrameName(odometry.front().parent);
      from = source.value + ", /tf_static";
    }
    poses.camera_ = TransformTree::FrameName(recorded.color_frame);
    const std::string chain = poses.tree_.Chain(poses.world_, poses.camera_,
                                                "--poses " + source.text + ": " + sequence.dir());
    poses.description_ = fmt::format("{}: {} ({})", source.text, chain, from);
  }
  poses.warnings_ =
      SkippedWarnings(source.kind == GivenPoseSource::Kind::kFile ? source.value : sequence.dir(),
                      undecoded, refused);
  return poses;
}

std::optional<Eigen::Isometry3d> GivenPoses::At(double stamp, LookupMiss* miss) const {
  return tree_.Lookup(world_, camera_, stamp, max_gap_s_, miss);
}

}  // namespace stillmap
