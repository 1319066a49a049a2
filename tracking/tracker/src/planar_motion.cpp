// The plane a ground robot's camera moves in, and poses put back on it (planar_motion.h).
#include "stillmap/tracking/planar_motion.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>

#include "median.h"

namespace stillmap {

std::optional<PlanarMotion> FitPlanarMotion(
    const std::vector<Eigen::Isometry3d>& world_from_camera) {
  if (world_from_camera.size() < 3) return std::nullopt;
  // R_i = Turn(heading_i about up) * mount: sum R_i = (sum of turns) * mount. The sum of turns
  // keeps the up axis at full length n and shortens the others to n * |mean heading vector|, so
  // the largest singular value's left vector is up, and the next two tell the heading spread.
  Eigen::Matrix3d sum = Eigen::Matrix3d::Zero();
  for (const Eigen::Isometry3d& pose : world_from_camera) sum += pose.linear();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(sum * sum.transpose());
  const Eigen::Vector3d& values = solver.eigenvalues();  // ascending
  if (!(values(2) > 0.0)) return std::nullopt;
  PlanarMotion plane;
  plane.heading_spread = 1.0 - std::sqrt(std::clamp(values(1) / values(2), 0.0, 1.0));
  if (plane.heading_spread < kMinPlanarHeadingSpread) return std::nullopt;
  plane.up_in_world = solver.eigenvectors().col(2).normalized();
  Eigen::Vector3d seen = Eigen::Vector3d::Zero();
  for (const Eigen::Isometry3d& pose : world_from_camera) {
    seen += pose.linear().transpose() * plane.up_in_world;
  }
  if (seen.y() > 0.0) {  // up is the image's -y for a level camera: say it that way round
    plane.up_in_world = -plane.up_in_world;
    seen = -seen;
  }
  plane.up_in_camera = seen.normalized();

  std::vector<double> heights;
  heights.reserve(world_from_camera.size());
  for (const Eigen::Isometry3d& pose : world_from_camera) {
    heights.push_back(plane.up_in_world.dot(pose.translation()));
  }
  plane.height_m = Median(heights);
  std::vector<double> height_deviations, tilts;
  height_deviations.reserve(heights.size());
  tilts.reserve(heights.size());
  double height_squares = 0.0, tilt_squares = 0.0;
  for (size_t i = 0; i < world_from_camera.size(); ++i) {
    height_deviations.push_back(std::abs(heights[i] - plane.height_m));
    const Eigen::Vector3d up = world_from_camera[i].linear().transpose() * plane.up_in_world;
    tilts.push_back(std::atan2(up.cross(plane.up_in_camera).norm(), up.dot(plane.up_in_camera)));
    height_squares += height_deviations.back() * height_deviations.back();
    tilt_squares += tilts.back() * tilts.back();
  }
  const double count = static_cast<double>(world_from_camera.size());
  plane.height_spread_m = std::sqrt(height_squares / count);
  plane.tilt_spread_deg = std::sqrt(tilt_squares / count) * 180.0 / M_PI;
  plane.height_median_deviation_m = Median(height_deviations);
  plane.tilt_median_deviation_deg = Median(tilts) * 180.0 / M_PI;
  return plane;
}

Eigen::Isometry3d OntoPlane(const PlanarMotion& plane, const Eigen::Isometry3d& world_from_camera) {
  Eigen::Isometry3d on_plane = world_from_camera;
  const double height = plane.up_in_world.dot(world_from_camera.translation());
  on_plane.translation() += (plane.height_m - height) * plane.up_in_world;
  // The turn that carries up_in_camera to the up this pose sees, about their common normal:
  // R' = R * turn sees up_in_world as turn^T * (R^T up) = up_in_camera, its heading unchanged.
  const Eigen::Vector3d seen = world_from_camera.linear().transpose() * plane.up_in_world;
  const Eigen::Quaterniond turn = Eigen::Quaterniond::FromTwoVectors(plane.up_in_camera, seen);
  on_plane.linear() = world_from_camera.linear() * turn.toRotationMatrix();
  return on_plane;
}

bool KeptToPlane(const PlanarMotion& plane) {
  return plane.height_median_deviation_m <= kRobotMaxHeightDeviationM &&
         plane.tilt_median_deviation_deg <= kRobotMaxTiltDeviationDeg;
}

const char* PlanarMotionModeName(PlanarMotionMode mode) {
  switch (mode) {
    case PlanarMotionMode::kOff:
      return "off";
    case PlanarMotionMode::kAuto:
      return "auto";
    case PlanarMotionMode::kOn:
      return "on";
  }
  return "auto";
}

}  // namespace stillmap
