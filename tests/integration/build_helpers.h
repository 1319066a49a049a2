// What the whole-build tests share.
#pragma once

#include <Eigen/Dense>
#include <cmath>
#include <string>
#include <vector>

#include "stillmap/io/cloud_files.h"
#include "stillmap/mapping/occupancy_grid.h"
#include "stillmap/pipeline/build_pipeline.h"
#include "test_util.h"

namespace stillmap {
namespace testing {

// Every file a default build writes.
inline constexpr const char* kOutputs[] = {"map.ply",
                                           "map.pcd",
                                           "map.bt",
                                           "map.ot",
                                           "trajectory.txt",
                                           "keyframes.txt",
                                           "grid.pgm",
                                           "grid.yaml",
                                           "mesh.glb",
                                           "report.json",
                                           "report.html",
                                           "config.yaml",
                                           "renders/grid_top.png",
                                           "renders/cloud_view_1.png",
                                           "renders/cloud_view_2.png"};

// Tracks a sequence with the bundle adjustment inline (the figure does not depend on thread
// timing) and no OctoMap (not under test), plus `settings`; the outputs go to `output_dir`, or to
// a temporary folder when it is empty.
inline BuildResult TrackRepeatably(const std::string& sequence,
                                   const std::vector<std::string>& settings = {},
                                   const std::string& output_dir = {}) {
  testing::TempDir dir;
  BuildRequest request;
  request.sequence_dir = sequence;
  request.output_dir = output_dir.empty() ? dir / "out" : output_dir;
  ApplySetArgument(&request.config, "tracking.background_bundle_adjustment=false");
  ApplySetArgument(&request.config, "octomap.enabled=false");
  for (const std::string& setting : settings) ApplySetArgument(&request.config, setting);
  return RunBuild(request);
}

// The floor of a map as the tests check it, by least squares independent of stillmap's fit: the
// plane z = a x + b y + c through the points within 5 cm of z = 0.
struct FloorCheck {
  double tilt_deg = 90.0;       // of the plane's normal from +z
  double height_at_origin = 0;  // c [m]
  double share_near = 0.0;      // of all points, within 5 cm of z = 0
  double share_below = 0.0;     // of all points, more than 10 cm below z = 0
};
inline FloorCheck CheckFloor(const std::vector<VoxelPoint>& points) {
  Eigen::Matrix3d normal_matrix = Eigen::Matrix3d::Zero();
  Eigen::Vector3d rhs = Eigen::Vector3d::Zero();
  size_t near = 0, below = 0;
  for (const VoxelPoint& p : points) {
    below += p.position.z() < -0.10f ? 1 : 0;
    if (std::abs(p.position.z()) >= 0.05f) continue;
    const Eigen::Vector3d v(p.position.x(), p.position.y(), 1.0);
    normal_matrix += v * v.transpose();
    rhs += v * p.position.z();
    ++near;
  }
  FloorCheck check;
  if (near < 3 || points.empty()) return check;
  const Eigen::Vector3d abc = normal_matrix.ldlt().solve(rhs);
  check.tilt_deg = std::atan(std::hypot(abc.x(), abc.y())) * 180.0 / M_PI;
  check.height_at_origin = abc.z();
  check.share_near = static_cast<double>(near) / static_cast<double>(points.size());
  check.share_below = static_cast<double>(below) / static_cast<double>(points.size());
  return check;
}

// Occupied cells of a grid with no cloud point more than `min_height` above the floor over them
// (the cloud in the 3-D outputs' frame, grid.world_from_grid placing the grid in it).
inline size_t PhantomCells(const OccupancyGrid& grid, const std::vector<VoxelPoint>& cloud,
                           double min_height = 0.10) {
  std::vector<bool> high(grid.cells.size(), false);
  const Eigen::Isometry3d grid_from_map = grid.world_from_grid.inverse();
  for (const VoxelPoint& p : cloud) {
    const Eigen::Vector3d g = grid_from_map * p.position.cast<double>();
    const std::optional<Eigen::Vector2i> cell = grid.CellAtGridPoint(g.x(), g.y());
    if (g.z() > min_height && cell) high[grid.Index(*cell)] = true;
  }
  size_t phantoms = 0;
  for (size_t k = 0; k < grid.cells.size(); ++k) {
    phantoms += grid.cells[k] == kGridOccupied && !high[k] ? 1 : 0;
  }
  return phantoms;
}

}  // namespace testing
}  // namespace stillmap
