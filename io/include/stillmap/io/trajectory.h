// Camera trajectories in the TUM format ("timestamp tx ty tz qx qy qz qw", camera-to-world).
#pragma once

#include <Eigen/Geometry>
#include <optional>
#include <string>
#include <vector>

namespace stillmap {

// A pose at a time: the camera's (or body's) pose in the world frame.
struct StampedPose {
  double time = 0.0;  // [s]
  Eigen::Isometry3d world_from_camera = Eigen::Isometry3d::Identity();
};

// The pose a share `s` (0..1) of the way from `a` to `b`: translation linear, rotation SLERP.
Eigen::Isometry3d InterpolatePose(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b, double s);

// The angle a motion turns by [deg].
double RotationAngleDeg(const Eigen::Isometry3d& motion);
// The distance between the centres of two cameras given as camera-from-world poses [m].
double CameraDistance(const Eigen::Isometry3d& a_camera_from_world,
                      const Eigen::Isometry3d& b_camera_from_world);
// True when the camera at `to` moved at least `distance_m` or turned at least `angle_deg` from
// `from` (a keyframe rule by motion alone).
bool MovedOrTurned(const Eigen::Isometry3d& from, const Eigen::Isometry3d& to, double distance_m,
                   double angle_deg);

// The poses alone (camera-to-world), in order.
std::vector<Eigen::Isometry3d> WorldFromCameras(const std::vector<StampedPose>& poses);

// The pose of the TUM fields "tx ty tz qx qy qz qw" (`v`, 7 finite numbers). Throws InputError
// at `where` (file:line) when the quaternion is far from unit length.
Eigen::Isometry3d PoseFromTumFields(const double* v, const std::string& where);

// A time-ordered list of poses with strictly increasing timestamps.
class Trajectory {
 public:
  Trajectory() = default;
  // Throws std::invalid_argument when times do not strictly increase.
  explicit Trajectory(std::vector<StampedPose> poses);

  // Reads a TUM trajectory. Throws InputError naming file and line for malformed lines, NaN or
  // infinite values, quaternions whose norm is off 1 by more than 1 % (smaller deviations, from
  // printing with few digits, are normalized), and unsorted or duplicate timestamps.
  static Trajectory ReadTum(const std::string& path);

  // Writes the TUM format (full double precision) to `path` directly; callers that need an
  // atomic output pass a temporary path. Throws std::runtime_error when the file cannot be written.
  void WriteTum(const std::string& path, const std::string& header = "") const;

  // The pose at `time`, interpolated (linear translation, SLERP rotation) between the two
  // bracketing poses, or nullopt when `time` lies outside the trajectory or the bracketing poses
  // are more than `max_gap` seconds apart (a pose is never invented across a hole).
  std::optional<Eigen::Isometry3d> Interpolate(double time, double max_gap) const;

  // Every pose right-multiplied by `b_from_c` (e.g. world_from_body * body_from_camera).
  Trajectory RightMultiplied(const Eigen::Isometry3d& b_from_c) const;

  const std::vector<StampedPose>& poses() const { return poses_; }
  std::vector<double> Times() const;
  size_t size() const { return poses_.size(); }
  bool empty() const { return poses_.empty(); }

 private:
  std::vector<StampedPose> poses_;
};

}  // namespace stillmap
