#include "stillmap/io/trajectory.h"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <iomanip>
#include <sstream>
#include <stdexcept>

#include "stillmap/io/error.h"
#include "stillmap/io/file_list.h"
#include "stillmap/io/input_files.h"

namespace stillmap {

std::vector<Eigen::Isometry3d> WorldFromCameras(const std::vector<StampedPose>& poses) {
  std::vector<Eigen::Isometry3d> out;
  out.reserve(poses.size());
  for (const StampedPose& pose : poses) out.push_back(pose.world_from_camera);
  return out;
}

Eigen::Isometry3d PoseFromTumFields(const double* v, const std::string& where) {
  const Eigen::Quaterniond q(v[6], v[3], v[4], v[5]);
  const double norm = q.norm();
  if (std::abs(norm - 1.0) > 0.01) {
    std::ostringstream message;
    message << where << ": quaternion (qx qy qz qw) has norm " << norm
            << ", expected 1 (is the column order 'tx ty tz qx qy qz qw'?)";
    throw InputError(message.str());
  }
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = q.normalized().toRotationMatrix();
  pose.translation() = Eigen::Vector3d(v[0], v[1], v[2]);
  return pose;
}

Trajectory::Trajectory(std::vector<StampedPose> poses) : poses_(std::move(poses)) {
  for (size_t i = 1; i < poses_.size(); ++i) {
    if (!(poses_[i].time > poses_[i - 1].time)) {
      throw std::invalid_argument("trajectory timestamps must strictly increase");
    }
  }
}

Trajectory Trajectory::ReadTum(const std::string& path) {
  std::vector<StampedPose> poses;
  std::vector<int> lines;
  int line_number = 0;
  for (const std::string& line : ReadTextLines(path, "trajectory file")) {
    ++line_number;
    const std::vector<std::string> fields = SplitFields(line);
    if (fields.empty() || fields[0][0] == '#') continue;
    const std::string where = WhereInFile(path, line_number);
    if (fields.size() != 8) {
      throw InputError(where + ": expected 8 numbers 'timestamp tx ty tz qx qy qz qw', got " +
                       std::to_string(fields.size()) + " field(s)");
    }
    double v[8];
    for (int i = 0; i < 8; ++i) {
      if (!ParseFiniteDouble(fields[i], &v[i])) {
        throw InputError(where + ": field " + std::to_string(i + 1) + " '" + Quoted(fields[i]) +
                         "' is not a finite number (NaN and inf are not poses)");
      }
    }
    StampedPose pose;
    pose.time = v[0];
    pose.world_from_camera = PoseFromTumFields(&v[1], where);
    if (!poses.empty() && pose.time <= poses.back().time) {
      std::ostringstream message;
      message << std::setprecision(16) << where << ": timestamp " << pose.time
              << (pose.time == poses.back().time ? " repeats" : " is earlier than") << " line "
              << lines.back() << "'s; timestamps must strictly increase";
      throw InputError(message.str());
    }
    poses.push_back(pose);
    lines.push_back(line_number);
  }
  if (poses.empty()) throw InputError(path + ": the trajectory holds no poses");
  return Trajectory(std::move(poses));
}

void Trajectory::WriteTum(const std::string& path, const std::string& header) const {
  std::ofstream out(path);
  if (!out) throw std::runtime_error(WriteFailure(path, "the trajectory"));
  if (!header.empty()) out << "# " << header << "\n";
  out << "# timestamp tx ty tz qx qy qz qw\n";
  char buffer[256];
  for (const StampedPose& pose : poses_) {
    const Eigen::Vector3d t = pose.world_from_camera.translation();
    const Eigen::Quaterniond q(pose.world_from_camera.rotation());
    std::snprintf(buffer, sizeof(buffer), "%.6f %.9f %.9f %.9f %.9f %.9f %.9f %.9f\n", pose.time,
                  t.x(), t.y(), t.z(), q.x(), q.y(), q.z(), q.w());
    out << buffer;
  }
  if (!out.flush()) throw std::runtime_error(WriteFailure(path, "the trajectory"));
}

std::optional<Eigen::Isometry3d> Trajectory::Interpolate(double time, double max_gap) const {
  if (poses_.empty() || time < poses_.front().time || time > poses_.back().time) {
    return std::nullopt;
  }
  std::vector<StampedPose>::const_iterator upper =
      std::lower_bound(poses_.begin(), poses_.end(), time,
                       [](const StampedPose& pose, double t) { return pose.time < t; });
  if (upper->time == time) return upper->world_from_camera;
  const StampedPose& a = *(upper - 1);
  const StampedPose& b = *upper;
  if (b.time - a.time > max_gap) return std::nullopt;
  return InterpolatePose(a.world_from_camera, b.world_from_camera,
                         (time - a.time) / (b.time - a.time));
}

double RotationAngleDeg(const Eigen::Isometry3d& motion) {
  return Eigen::AngleAxisd(motion.linear()).angle() * 180.0 / M_PI;
}

double CameraDistance(const Eigen::Isometry3d& a_camera_from_world,
                      const Eigen::Isometry3d& b_camera_from_world) {
  return (a_camera_from_world.inverse().translation() - b_camera_from_world.inverse().translation())
      .norm();
}

bool MovedOrTurned(const Eigen::Isometry3d& from, const Eigen::Isometry3d& to, double distance_m,
                   double angle_deg) {
  const Eigen::Isometry3d motion = from.inverse() * to;
  return motion.translation().norm() >= distance_m || RotationAngleDeg(motion) >= angle_deg;
}

Eigen::Isometry3d InterpolatePose(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b,
                                  double s) {
  const Eigen::Quaterniond qa(a.rotation());
  const Eigen::Quaterniond qb(b.rotation());
  Eigen::Isometry3d result = Eigen::Isometry3d::Identity();
  result.linear() = qa.slerp(s, qb).toRotationMatrix();
  result.translation() = (1.0 - s) * a.translation() + s * b.translation();
  return result;
}

Trajectory Trajectory::RightMultiplied(const Eigen::Isometry3d& b_from_c) const {
  std::vector<StampedPose> poses = poses_;
  for (StampedPose& pose : poses) pose.world_from_camera = pose.world_from_camera * b_from_c;
  return Trajectory(std::move(poses));
}

std::vector<double> Trajectory::Times() const {
  std::vector<double> times;
  times.reserve(poses_.size());
  for (const StampedPose& pose : poses_) times.push_back(pose.time);
  return times;
}

}  // namespace stillmap
