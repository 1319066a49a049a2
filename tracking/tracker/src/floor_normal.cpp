// The floor in one depth image, and the median of many floors' normals (floor_normal.h).
#include "stillmap/tracking/floor_normal.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>

#include "median.h"

namespace stillmap {
namespace {

struct Reading {
  double height;  // along the pose's up [m]
  Eigen::Vector3d point_in_camera;
};

// The sampled readings within range, with their heights along `up`.
std::vector<Reading> SampledReadings(const std::vector<Eigen::Vector2f>& rays,
                                     const cv::Mat& depth_m, const Eigen::Vector3d& up,
                                     const FloorNormalOptions& options) {
  std::vector<Reading> readings;
  const int step = options.stride_px;
  readings.reserve(depth_m.total() / static_cast<size_t>(step * step) + 1);  // about
  for (int v = step / 2; v < depth_m.rows; v += step) {
    const float* z = depth_m.ptr<float>(v);
    for (int u = step / 2; u < depth_m.cols; u += step) {
      if (!(z[u] > 0.0f) || z[u] > options.max_depth_m) continue;
      const Eigen::Vector2f& ray = rays[static_cast<size_t>(v) * depth_m.cols + u];
      const Eigen::Vector3d point(ray.x() * z[u], ray.y() * z[u], z[u]);
      readings.push_back({point.dot(up), point});
    }
  }
  return readings;
}

// The lowest height at which a layer `layer_m` thick holds `count` readings (sorted by height).
std::optional<double> LowestLayer(const std::vector<Reading>& sorted, double layer_m,
                                  size_t count) {
  size_t top = 0;
  for (size_t bottom = 0; bottom < sorted.size(); ++bottom) {
    top = std::max(top, bottom);
    while (top < sorted.size() && sorted[top].height <= sorted[bottom].height + layer_m) ++top;
    if (top - bottom >= count) return sorted[bottom].height;
  }
  return std::nullopt;
}

// The least-squares plane through points: its unit normal (on `up`'s side) and a point on it.
std::pair<Eigen::Vector3d, Eigen::Vector3d> FitPlane(const std::vector<Eigen::Vector3d>& points,
                                                     const Eigen::Vector3d& up) {
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3d& p : points) centroid += p;
  centroid /= static_cast<double>(points.size());
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
  for (const Eigen::Vector3d& p : points) scatter += (p - centroid) * (p - centroid).transpose();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(scatter);
  Eigen::Vector3d normal = solver.eigenvectors().col(0).normalized();  // smallest eigenvalue
  if (normal.dot(up) < 0.0) normal = -normal;
  return {normal, centroid};
}

}  // namespace

std::optional<Eigen::Vector3d> FloorNormalInCamera(const std::vector<Eigen::Vector2f>& rays,
                                                   const cv::Mat& depth_m,
                                                   const Eigen::Vector3d& up_in_camera,
                                                   const FloorNormalOptions& options) {
  if (depth_m.empty() || rays.size() != depth_m.total()) return std::nullopt;
  const Eigen::Vector3d up = up_in_camera.normalized();
  std::vector<Reading> readings = SampledReadings(rays, depth_m, up, options);
  std::sort(readings.begin(), readings.end(),
            [](const Reading& a, const Reading& b) { return a.height < b.height; });
  const size_t wanted = std::max(static_cast<size_t>(options.min_points),
                                 static_cast<size_t>(options.min_layer_share * readings.size()));
  const std::optional<double> floor_height = LowestLayer(readings, options.layer_m, wanted);
  if (!floor_height) return std::nullopt;
  std::vector<Eigen::Vector3d> inliers;
  for (const Reading& r : readings) {
    if (r.height > *floor_height + options.layer_m) break;
    inliers.push_back(r.point_in_camera);
  }
  // Refined twice on the readings near the plane: the layer's cut along the pose's up, a little
  // tilted from the floor's, leaves out a sliver of the floor far away and takes in one of what
  // stands on it.
  Eigen::Vector3d normal = up;
  for (int round = 0; round < 3; ++round) {
    if (inliers.size() < static_cast<size_t>(options.min_points)) return std::nullopt;
    const auto [fitted, on_plane] = FitPlane(inliers, up);
    normal = fitted;
    if (round == 2) break;
    inliers.clear();
    for (const Reading& r : readings) {
      if (std::abs((r.point_in_camera - on_plane).dot(normal)) <= options.inlier_m) {
        inliers.push_back(r.point_in_camera);
      }
    }
  }
  const double angle_deg = std::atan2(normal.cross(up).norm(), normal.dot(up)) * 180.0 / M_PI;
  if (angle_deg > options.max_angle_deg) return std::nullopt;
  return normal;
}

std::optional<Eigen::Vector3d> MedianDirection(const std::vector<Eigen::Vector3d>& directions) {
  if (directions.empty()) return std::nullopt;
  Eigen::Vector3d median;
  for (int axis = 0; axis < 3; ++axis) {
    std::vector<double> values;
    values.reserve(directions.size());
    for (const Eigen::Vector3d& d : directions) values.push_back(d(axis));
    median(axis) = Median(values);
  }
  if (!(median.norm() > 0.0)) return std::nullopt;
  return median.normalized();
}

}  // namespace stillmap
