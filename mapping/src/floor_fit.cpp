// The floor under an occupancy map (FindFloor, occupancy_grid.h): given, fitted with PCL's RANSAC
// to the occupied voxels, or, without a horizontal plane, a low percentile of their heights.
#include <fmt/format.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <pcl/sample_consensus/ransac.h>
#include <pcl/sample_consensus/sac_model_perpendicular_plane.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <iterator>
#include <optional>
#include <string>
#include <unordered_set>
#include <vector>

#include "stillmap/io/error.h"
#include "stillmap/io/option_names.h"
#include "stillmap/mapping/occupancy_grid.h"
#include "voxel_key.h"

namespace stillmap {
namespace {

constexpr double kDegree = M_PI / 180.0;

using Cloud = pcl::PointCloud<pcl::PointXYZ>;

// One plane of the fit.
struct FloorCandidate {
  Eigen::Vector3d up;
  double offset;
  size_t inliers;
  double mean_height;  // along the hint
};

// One point of the cloud per `cell` voxel (the first in it).
pcl::shared_ptr<Cloud> ThinnedCloud(const std::vector<VoxelPoint>& points, double cell) {
  auto cloud = pcl::make_shared<Cloud>();
  std::unordered_set<std::int64_t> taken;
  taken.reserve(points.size() / 8);
  for (const VoxelPoint& p : points) {
    const Eigen::Vector3d index = (p.position.cast<double>() / cell).array().floor();
    if (taken
            .insert(VoxelKey(static_cast<std::int64_t>(index.x()),
                             static_cast<std::int64_t>(index.y()),
                             static_cast<std::int64_t>(index.z())))
            .second)
      cloud->push_back(pcl::PointXYZ(p.position.x(), p.position.y(), p.position.z()));
  }
  return cloud;
}

pcl::shared_ptr<Cloud> OccupiedVoxels(const OccupancyMap& map) {
  auto cloud = pcl::make_shared<Cloud>();
  map.ForEachLeaf([&](const Eigen::Vector3d& centre, double, bool occupied) {
    if (occupied)
      cloud->push_back(pcl::PointXYZ(static_cast<float>(centre.x()), static_cast<float>(centre.y()),
                                     static_cast<float>(centre.z())));
  });
  return cloud;
}

// Planes within max_floor_tilt_deg of `hint`, largest first, each fitted to the voxels the
// earlier ones left, while they are large enough.
std::vector<FloorCandidate> FitPlanes(const pcl::shared_ptr<Cloud>& cloud,
                                      const Eigen::Vector3d& hint, double threshold,
                                      const GridOptions& options) {
  std::vector<FloorCandidate> candidates;
  std::vector<int> remaining(cloud->size());
  for (size_t i = 0; i < remaining.size(); ++i) remaining[i] = static_cast<int>(i);
  const auto min_points = static_cast<size_t>(options.floor_min_points);
  const size_t min_inliers = std::max(
      min_points, cloud->size() * static_cast<size_t>(options.floor_min_inliers_per_mille) / 1000);
  for (int round = 0; round < options.floor_ransac_rounds && remaining.size() >= min_points;
       ++round) {
    auto model = pcl::make_shared<pcl::SampleConsensusModelPerpendicularPlane<pcl::PointXYZ>>(
        cloud, remaining);
    model->setAxis(hint.cast<float>());
    model->setEpsAngle(options.max_floor_tilt_deg * kDegree);
    pcl::RandomSampleConsensus<pcl::PointXYZ> ransac(model, threshold);
    ransac.setMaxIterations(options.floor_ransac_iterations);
    if (!ransac.computeModel()) break;
    std::vector<int> inliers;
    ransac.getInliers(inliers);
    Eigen::VectorXf coefficients;
    ransac.getModelCoefficients(coefficients);
    if (inliers.size() < min_inliers || coefficients.size() != 4) {
      break;
    }
    Eigen::Vector3d up = coefficients.head<3>().cast<double>();
    double offset = coefficients[3];
    const double norm = up.norm();
    up /= norm;
    offset /= norm;
    if (up.dot(hint) < 0.0) {
      up = -up;
      offset = -offset;
    }
    double sum = 0.0;
    for (int index : inliers)
      sum += hint.dot(cloud->points[static_cast<size_t>(index)].getVector3fMap().cast<double>());
    candidates.push_back({up, offset, inliers.size(), sum / static_cast<double>(inliers.size())});
    std::vector<int> rest;
    std::sort(inliers.begin(), inliers.end());
    std::set_difference(remaining.begin(), remaining.end(), inliers.begin(), inliers.end(),
                        std::back_inserter(rest));
    remaining.swap(rest);
  }
  return candidates;
}

// The lowest plane among those at least a quarter the size of the largest (a table top is
// smaller than the floor, a wall is not horizontal); nullptr when there is none.
const FloorCandidate* LowestLargePlane(const std::vector<FloorCandidate>& candidates) {
  size_t largest = 0;
  for (const FloorCandidate& c : candidates) largest = std::max(largest, c.inliers);
  const FloorCandidate* best = nullptr;
  for (const FloorCandidate& c : candidates) {
    if (4 * c.inliers < largest) continue;
    if (best == nullptr || c.mean_height < best->mean_height) best = &c;
  }
  return best;
}

// The plane normal to `hint` through the 2nd percentile of the voxels' heights along it.
void PercentileFloor(const Cloud& cloud, const Eigen::Vector3d& hint, FloorPlane* floor) {
  std::vector<double> heights;
  heights.reserve(cloud.size());
  for (const pcl::PointXYZ& p : cloud.points) {
    heights.push_back(hint.dot(p.getVector3fMap().cast<double>()));
  }
  const auto nth = heights.begin() + static_cast<long>(heights.size() / 50);
  std::nth_element(heights.begin(), nth, heights.end());
  floor->up = hint;
  floor->offset = -*nth;
  floor->source =
      "no horizontal plane found: the 2nd percentile of the map's heights along the cameras' up";
}

double TiltDeg(const FloorPlane& floor, const Eigen::Vector3d& hint) {
  return std::acos(std::clamp(floor.up.dot(hint), -1.0, 1.0)) / kDegree;
}

// The floor fitted to `cloud` (voxel centres or thinned points), `threshold` the plane's
// inlier distance [m].
FloorPlane FitFloor(const pcl::shared_ptr<Cloud>& cloud, double threshold,
                    const Eigen::Vector3d& hint, const GridOptions& options) {
  FloorPlane floor;
  if (cloud->empty()) {
    floor.up = hint;
    floor.offset = 0.0;
    floor.source =
        "none found (empty map): the plane through the world origin, normal to the "
        "cameras' mean up";
    return floor;
  }
  const std::vector<FloorCandidate> candidates = FitPlanes(cloud, hint, threshold, options);
  if (const FloorCandidate* best = LowestLargePlane(candidates)) {
    floor.up = best->up;
    floor.offset = best->offset;
    floor.inliers = best->inliers;
    floor.source = "fitted";
  } else {
    PercentileFloor(*cloud, hint, &floor);
  }
  floor.tilt_to_cameras_deg = TiltDeg(floor, hint);
  return floor;
}

Eigen::Vector3d Hint(const Eigen::Vector3d& cameras_up) {
  return cameras_up.norm() > 0.0 ? cameras_up.normalized() : Eigen::Vector3d(0, -1, 0);
}

// The floor given as grid.floor, if it is; its normal turned to point up. Throws InputError when
// the plane is farther from level than a fitted floor may be (a wall, or the axes mixed up).
std::optional<FloorPlane> GivenFloor(const Eigen::Vector3d& hint, const GridOptions& options) {
  if (!options.floor) return std::nullopt;
  FloorPlane floor;
  const double norm = options.floor->head<3>().norm();
  floor.up = options.floor->head<3>() / norm;
  floor.offset = (*options.floor)[3] / norm;
  if (floor.up.dot(hint) < 0.0) floor.up = -floor.up, floor.offset = -floor.offset;
  floor.source = fmt::format("given ({})", OptionKey(options, options.floor));
  floor.tilt_to_cameras_deg = TiltDeg(floor, hint);
  if (floor.tilt_to_cameras_deg > options.max_floor_tilt_deg) {
    throw InputError(
        fmt::format("{}: the plane's normal lies ", OptionKey(options, options.floor)) +
        std::to_string(static_cast<int>(std::lround(floor.tilt_to_cameras_deg))) +
        fmt::format(" deg from the cameras' up direction, more than {} (",
                    OptionKey(options, options.max_floor_tilt_deg)) +
        std::to_string(options.max_floor_tilt_deg) +
        "): not a floor; give 'a b c d' with (a, b, c) the floor's normal in the poses' "
        "frame (when tracking, the first camera's: x right, y down, z forward, "
        "e.g. '0 -1 0 1.2')");
  }
  return floor;
}

}  // namespace

FloorPlane FindFloor(const OccupancyMap& map, const Eigen::Vector3d& cameras_up,
                     const GridOptions& options) {
  const Eigen::Vector3d hint = Hint(cameras_up);
  if (std::optional<FloorPlane> given = GivenFloor(hint, options)) return *given;
  return FitFloor(OccupiedVoxels(map), map.resolution(), hint, options);
}

FloorPlane FindFloor(const std::vector<VoxelPoint>& cloud, double cell,
                     const Eigen::Vector3d& cameras_up, const GridOptions& options) {
  const Eigen::Vector3d hint = Hint(cameras_up);
  if (std::optional<FloorPlane> given = GivenFloor(hint, options)) return *given;
  return FitFloor(ThinnedCloud(cloud, cell), cell, hint, options);
}

FloorPlane RefineFloor(const FloorPlane& floor, const std::vector<VoxelPoint>& cloud, double band) {
  if (floor.source != "fitted") return floor;
  FloorPlane refined = floor;
  for (const double width : {band, band / 2.0, band / 4.0, band / 8.0}) {
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    Eigen::Matrix3d products = Eigen::Matrix3d::Zero();
    std::vector<double> heights;
    for (const VoxelPoint& p : cloud) {
      const Eigen::Vector3d point = p.position.cast<double>();
      const double height = refined.Height(point);
      if (std::abs(height) > width) continue;
      sum += point;
      products += point * point.transpose();
      heights.push_back(height);
    }
    if (heights.size() < 3) return refined;
    const double n = static_cast<double>(heights.size());
    const Eigen::Vector3d centroid = sum / n;
    const Eigen::Matrix3d covariance = products / n - centroid * centroid.transpose();
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(covariance);
    Eigen::Vector3d normal = solver.eigenvectors().col(0);  // of the smallest eigenvalue
    if (normal.dot(floor.up) < 0.0) normal = -normal;
    const auto middle = heights.begin() + static_cast<long>(heights.size() / 2);
    std::nth_element(heights.begin(), middle, heights.end());
    const Eigen::Vector3d on_floor = centroid - (refined.Height(centroid) - *middle) * refined.up;
    if (normal.dot(floor.up) > std::cos(5.0 * kDegree)) refined.up = normal.normalized();
    refined.offset = -refined.up.dot(on_floor);
  }
  return refined;
}

}  // namespace stillmap
