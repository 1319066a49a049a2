#include "stillmap/mapping/occupancy_grid.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/core/utility.hpp>
#include <stdexcept>

#include "stillmap/io/error.h"
#include "stillmap/io/option_names.h"

namespace stillmap {

Eigen::Matrix3d FloorAxes(const Eigen::Vector3d& up) {
  Eigen::Vector3d x = Eigen::Vector3d::UnitX();
  if (std::abs(up.dot(x)) > 0.9) x = Eigen::Vector3d::UnitZ();
  x = (x - up.dot(x) * up).normalized();
  const Eigen::Vector3d y = up.cross(x);
  Eigen::Matrix3d rows;
  rows.row(0) = x.transpose();
  rows.row(1) = y.transpose();
  rows.row(2) = up.transpose();
  return rows;
}

Eigen::Isometry3d FloorFrame(const FloorPlane& floor, const Eigen::Vector3d& above,
                             const Eigen::Vector3d& forward) {
  const Eigen::Vector3d& up = floor.up;
  Eigen::Vector3d x = forward - up.dot(forward) * up;
  if (!(x.norm() > std::sin(25.0 * M_PI / 180.0) * forward.norm())) {
    x = FloorAxes(up).row(0).transpose();
  }
  Eigen::Isometry3d world_from_floor = Eigen::Isometry3d::Identity();
  world_from_floor.linear().col(0) = x.normalized();
  world_from_floor.linear().col(1) = up.cross(x.normalized());
  world_from_floor.linear().col(2) = up;
  world_from_floor.translation() = above - floor.Height(above) * up;
  return world_from_floor;
}

Eigen::Vector3d MeanCameraUp(const std::vector<Eigen::Isometry3d>& world_from_cameras) {
  Eigen::Vector3d up = Eigen::Vector3d::Zero();
  for (const Eigen::Isometry3d& pose : world_from_cameras) up -= pose.linear().col(1);
  return up;
}

void GridOptions::Validate() const {
  // The band is sampled at the OctoMap's resolution in every cell: 100 m bounds the work.
  if (!(min_height >= 0.0 && max_height > min_height && max_height <= 100.0)) {
    throw InputError(fmt::format("{} must be >= 0 and {} above it, at most 100 m",
                                 OptionKey(*this, min_height), OptionKey(*this, max_height)));
  }
  if (!(resolution >= 0.005 && resolution <= 5.0)) {
    throw InputError(fmt::format("{} must be between 0.005 and 5 m", OptionKey(*this, resolution)));
  }
  if (min_cloud_points < 0)
    throw InputError(fmt::format("{} must be >= 0", OptionKey(*this, min_cloud_points)));
  if (!(surface_spill_m >= 0.0 && surface_spill_m <= 1.0)) {
    throw InputError(fmt::format("{} must be 0..1 m", OptionKey(*this, surface_spill_m)));
  }
  if (!(surface_spill_ratio >= 1.0 && surface_spill_ratio <= 1e6)) {
    throw InputError(fmt::format("{} must be 1..1e6", OptionKey(*this, surface_spill_ratio)));
  }
  if (!(min_unseen_layer_m >= 0.0 && min_unseen_layer_m <= max_height - min_height)) {
    throw InputError(fmt::format("{} must be 0 (off) up to the band's height",
                                 OptionKey(*this, min_unseen_layer_m)));
  }
  if (unseen_layer_block_step < 1 || unseen_layer_block_step > 64) {
    throw InputError(fmt::format("{} must be 1..64", OptionKey(*this, unseen_layer_block_step)));
  }
  if (!(unseen_layer_grazing_deg > 0.0 && unseen_layer_grazing_deg <= 90.0)) {
    throw InputError(
        fmt::format("{} must be in (0, 90] degrees", OptionKey(*this, unseen_layer_grazing_deg)));
  }
  if (!(occupied_probability >= 0.5 && occupied_probability < 1.0)) {
    throw InputError(fmt::format("{} must be in [0.5, 1)", OptionKey(*this, occupied_probability)));
  }
  if (!(confirm_probability >= 0.5 && confirm_probability < 1.0)) {
    throw InputError(fmt::format("{} must be in [0.5, 1)", OptionKey(*this, confirm_probability)));
  }
  if (floor_ransac_rounds < 1 || floor_ransac_rounds > 100 || floor_ransac_iterations < 1 ||
      floor_ransac_iterations > 1000000 || floor_min_points < 3 ||
      floor_min_inliers_per_mille < 0 || floor_min_inliers_per_mille > 1000) {
    throw InputError(fmt::format(
        "{} must be 1..100, {} 1..1000000, "
        "{} at least 3 and {} 0..1000",
        OptionKey(*this, floor_ransac_rounds), OptionKey(*this, floor_ransac_iterations),
        OptionKey(*this, floor_min_points), OptionKey(*this, floor_min_inliers_per_mille)));
  }
  if (!(max_floor_tilt_deg > 0.0 && max_floor_tilt_deg < 90.0)) {
    throw InputError(fmt::format("{} must be in (0, 90)", OptionKey(*this, max_floor_tilt_deg)));
  }
  if (floor && !(floor->head<3>().norm() > 0.0 && floor->allFinite())) {
    throw InputError(fmt::format("{}: the plane 'a b c d' needs a non-zero normal (a, b, c)",
                                 OptionKey(*this, floor)));
  }
}

std::optional<Eigen::Vector2i> OccupancyGrid::CellOf(const Eigen::Vector3d& point_in_world) const {
  const Eigen::Vector3d g = world_from_grid.inverse() * point_in_world;
  return CellAtGridPoint(g.x(), g.y());
}

std::optional<Eigen::Vector2i> OccupancyGrid::CellAtGridPoint(double x, double y) const {
  const int i = static_cast<int>(std::floor((x - origin.x()) / resolution));
  const int j = static_cast<int>(std::floor((y - origin.y()) / resolution));
  if (!Contains(i, j)) return std::nullopt;
  return Eigen::Vector2i(i, j);
}

size_t OccupancyGrid::Count(std::int8_t value) const {
  return static_cast<size_t>(std::count(cells.begin(), cells.end(), value));
}

namespace {

// Sizes `grid` to the known voxels near its band, projected (false: none, the grid stays empty).
bool FitExtent(const OccupancyMap& map, const Eigen::Isometry3d& grid_from_world, double floor_low,
               double max_height, OccupancyGrid* grid) {
  const double resolution = grid->resolution;
  Eigen::Vector2d low(std::numeric_limits<double>::infinity(),
                      std::numeric_limits<double>::infinity());
  Eigen::Vector2d high = -low;
  map.ForEachLeaf([&](const Eigen::Vector3d& centre, double size, bool) {
    const Eigen::Vector3d g = grid_from_world * centre;
    const double reach = 0.87 * size;  // half the cube's diagonal
    if (g.z() + reach < floor_low || g.z() - reach > max_height) return;
    low = low.cwiseMin(g.head<2>() - Eigen::Vector2d::Constant(reach));
    high = high.cwiseMax(g.head<2>() + Eigen::Vector2d::Constant(reach));
  });
  if (!(low.x() <= high.x())) return false;
  // Cells are centred on multiples of the resolution, so that the grid frame's origin (under the
  // first camera) is a cell's centre, not a corner shared by four.
  auto index = [resolution](double v) {
    return static_cast<int>(std::floor(v / resolution + 0.5));
  };
  const int i_min = index(low.x()), j_min = index(low.y());
  grid->width = index(high.x()) - i_min + 1;
  grid->height = index(high.y()) - j_min + 1;
  grid->origin = Eigen::Vector2d((i_min - 0.5) * resolution, (j_min - 0.5) * resolution);
  grid->cells.assign(static_cast<size_t>(grid->width) * static_cast<size_t>(grid->height),
                     kGridUnknown);
  return true;
}

// Each cell's column is looked up in the OctoMap at voxel spacing across the cell, every half
// voxel in height: the grid gets exactly what lies over each cell, whatever its angle to the
// OctoMap's axes and its size (splatting voxels instead either leaves gaps or grows obstacles by
// up to a cell). Returns the strongest occupancy probability in each cell's band.
std::vector<float> ClassifyCells(const OccupancyMap& map, const GridOptions& options,
                                 double floor_low, OccupancyGrid* grid_out) {
  OccupancyGrid& grid = *grid_out;
  const double resolution = grid.resolution;
  const double voxel = map.resolution();
  const double step = voxel / 2.0;
  const int samples = std::max(1, static_cast<int>(std::ceil(resolution / voxel - 1e-6)));
  std::vector<double> band, floor_band, offsets;
  for (double h = options.min_height; h <= options.max_height + 1e-9; h += step) band.push_back(h);
  for (double h = floor_low; h < options.min_height; h += step) floor_band.push_back(h);
  for (int k = 0; k < samples; ++k) offsets.push_back((k + 0.5) * resolution / samples);
  std::vector<float> support(grid.cells.size(), -1.0f);
  const Eigen::Vector3d up = grid.world_from_grid.linear().col(2);
  cv::parallel_for_(cv::Range(0, grid.height), [&](const cv::Range& rows) {
    for (int j = rows.start; j < rows.end; ++j) {
      for (int i = 0; i < grid.width; ++i) {
        // Free needs evidence near the floor: the band's lowest voxels seen free, or the floor
        // itself seen (below). Space seen free only higher up (over a box, into its shadow) may
        // hide a low obstacle, and stays unknown.
        bool occupied = false, free = false, floor_seen = false;
        double strongest = -1.0;
        for (double dx : offsets) {
          for (double dy : offsets) {
            const Eigen::Vector3d column =
                grid.world_from_grid * Eigen::Vector3d(grid.origin.x() + i * resolution + dx,
                                                       grid.origin.y() + j * resolution + dy, 0.0);
            for (double h : band) {
              const double p = map.Occupancy(column + h * up);
              strongest = std::max(strongest, p);
              occupied = occupied || p > options.occupied_probability;
              free = free || (p >= 0.0 && h < options.min_height + 2.0 * voxel);
            }
            for (size_t k = 0; k < floor_band.size() && !floor_seen && !occupied && !free; ++k) {
              floor_seen = map.Occupancy(column + floor_band[k] * up) > 0.5;
            }
          }
        }
        // With nothing known above it in the band, the floor seen makes the cell free.
        free = free || floor_seen;
        const size_t cell =
            static_cast<size_t>(j) * static_cast<size_t>(grid.width) + static_cast<size_t>(i);
        support[cell] = static_cast<float>(strongest);
        grid.cells[cell] = occupied ? kGridOccupied : free ? kGridFree : kGridUnknown;
      }
    }
  });
  return support;
}

// The cleaned cloud's points over each cell: how many lie in the band and below it (the floor),
// and the extent of the band's points across the cell [m, from the cell's lower-left corner].
struct CellPoints {
  int in_band = 0;
  int on_floor = 0;
  Eigen::Vector2f low = Eigen::Vector2f::Constant(std::numeric_limits<float>::infinity());
  Eigen::Vector2f high = -low;
  // What an occupied cell the cloud does not bear out becomes: free when the cloud shows the
  // floor there, else unknown.
  std::int8_t WithoutObstacle() const { return on_floor > 0 ? kGridFree : kGridUnknown; }
};

std::vector<CellPoints> CountCloudPoints(const std::vector<VoxelPoint>& cloud,
                                         const GridOptions& options, double floor_low,
                                         const OccupancyGrid& grid) {
  std::vector<CellPoints> cells(grid.cells.size());
  const Eigen::Isometry3f grid_from_world = grid.world_from_grid.inverse().cast<float>();
  const float resolution = static_cast<float>(grid.resolution);
  for (const VoxelPoint& point : cloud) {
    const Eigen::Vector3f g = grid_from_world * point.position;
    if (g.z() < floor_low || g.z() > options.max_height) continue;
    const std::optional<Eigen::Vector2i> cell = grid.CellAtGridPoint(g.x(), g.y());
    if (!cell) continue;
    CellPoints& counts = cells[grid.Index(*cell)];
    if (g.z() < options.min_height) {
      ++counts.on_floor;
      continue;
    }
    ++counts.in_band;
    const Eigen::Vector2f corner = grid.origin.cast<float>() + resolution * cell->cast<float>();
    counts.low = counts.low.cwiseMin(g.head<2>() - corner);
    counts.high = counts.high.cwiseMax(g.head<2>() - corner);
  }
  return cells;
}

// Occupied cells whose band holds fewer than min_cloud_points points of the cleaned cloud: free
// when the cloud shows the floor there (points below min_height), else unknown.
void RequireCloudSupport(const std::vector<CellPoints>& points, const GridOptions& options,
                         OccupancyGrid* grid) {
  for (size_t k = 0; k < grid->cells.size(); ++k) {
    if (grid->cells[k] != kGridOccupied || points[k].in_band >= options.min_cloud_points) continue;
    grid->cells[k] = points[k].WithoutObstacle();
    ++grid->unsupported_cells;
  }
}

// A surface lying just inside one cell puts a few of its points, scattered by depth noise and
// pose error, over the cell next to it: that cell is occupied only by the neighbour's surface
// (a wall one cell thicker than it is). An occupied cell whose band points all lie within
// surface_spill_m (at most half a cell) of its edge with an occupied 4-neighbour holding at least
// surface_spill_ratio times as many is that spill: free when the cloud shows the floor there, else
// unknown. Decided on the cells as they are before any is changed.
void DropSurfaceSpill(const std::vector<CellPoints>& points, const GridOptions& options,
                      OccupancyGrid* grid) {
  const float reach = static_cast<float>(std::min(options.surface_spill_m, 0.5 * grid->resolution));
  const float far_edge = static_cast<float>(grid->resolution) - reach;
  // The neighbours across a cell's edges -x, +x, -y, +y.
  constexpr int kStepI[4] = {-1, 1, 0, 0}, kStepJ[4] = {0, 0, -1, 1};
  std::vector<size_t> spilled;
  for (int j = 0; j < grid->height; ++j) {
    for (int i = 0; i < grid->width; ++i) {
      const size_t k = grid->Index(Eigen::Vector2i(i, j));
      const CellPoints& cell = points[k];
      if (grid->cells[k] != kGridOccupied || cell.in_band == 0) continue;
      // Whether all its points lie near that edge.
      const bool near_edge[4] = {cell.high.x() <= reach, cell.low.x() >= far_edge,
                                 cell.high.y() <= reach, cell.low.y() >= far_edge};
      for (int e = 0; e < 4; ++e) {
        const int a = i + kStepI[e], b = j + kStepJ[e];
        if (!near_edge[e] || !grid->Contains(a, b)) continue;
        const size_t n = grid->Index(Eigen::Vector2i(a, b));
        if (grid->cells[n] == kGridOccupied &&
            points[n].in_band >= options.surface_spill_ratio * cell.in_band) {
          spilled.push_back(k);
          break;
        }
      }
    }
  }
  for (size_t k : spilled) grid->cells[k] = points[k].WithoutObstacle();
  grid->spilled_cells = spilled.size();
}

// Hysteresis: an occupied cell whose voxels were hit only weakly (about once, as the remnant of a
// person at a mask's edge is) stays occupied only when connected (8-neighbours, through occupied
// cells) to a cell confirmed above confirm_probability; otherwise it is unknown.
void DropUnconfirmed(const std::vector<float>& support, double confirm_probability,
                     OccupancyGrid* grid) {
  std::vector<std::uint8_t> reached(grid->cells.size(), 0);
  std::vector<int> queue;
  for (size_t k = 0; k < grid->cells.size(); ++k) {
    if (grid->cells[k] == kGridOccupied && support[k] > confirm_probability) {
      reached[k] = 1;
      queue.push_back(static_cast<int>(k));
    }
  }
  for (size_t head = 0; head < queue.size(); ++head) {
    const int i = queue[head] % grid->width, j = queue[head] / grid->width;
    for (int dj = -1; dj <= 1; ++dj) {
      for (int di = -1; di <= 1; ++di) {
        const int a = i + di, b = j + dj;
        if (!grid->Contains(a, b)) continue;
        const size_t k = grid->Index(Eigen::Vector2i(a, b));
        if (reached[k] != 0 || grid->cells[k] != kGridOccupied) continue;
        reached[k] = 1;
        queue.push_back(static_cast<int>(k));
      }
    }
  }
  for (size_t k = 0; k < grid->cells.size(); ++k) {
    if (grid->cells[k] == kGridOccupied && reached[k] == 0) {
      grid->cells[k] = kGridUnknown;
      ++grid->unconfirmed_cells;
    }
  }
}

}  // namespace

OccupancyGrid ProjectToGrid(const GridSources& sources, const GridOptions& options) {
  options.Validate();
  const OccupancyMap& map = *sources.map;
  OccupancyGrid grid;
  grid.resolution = options.resolution;
  grid.floor = sources.floor;
  grid.min_height = options.min_height;
  grid.max_height = options.max_height;
  grid.world_from_grid = sources.world_from_grid;
  // Occupied voxels this far below min_height (and above the plane's fit error) count as floor.
  const double floor_low = -std::max(2.0 * map.resolution(), 0.1);
  if (!FitExtent(map, grid.world_from_grid.inverse(), floor_low, options.max_height, &grid)) {
    return grid;  // nothing near the band: an empty grid
  }
  const std::vector<float> support = ClassifyCells(map, options, floor_low, &grid);
  if (sources.cloud != nullptr) {
    const std::vector<CellPoints> points =
        CountCloudPoints(*sources.cloud, options, floor_low, grid);
    if (options.min_cloud_points > 0) RequireCloudSupport(points, options, &grid);
    if (options.surface_spill_m > 0.0) DropSurfaceSpill(points, options, &grid);
  }
  if (options.confirm_probability > options.occupied_probability) {
    DropUnconfirmed(support, options.confirm_probability, &grid);
  }
  if (sources.start) {
    const std::optional<Eigen::Vector2i> cell = grid.CellOf(*sources.start);
    if (cell && grid.cells[grid.Index(*cell)] == kGridUnknown) {
      grid.cells[grid.Index(*cell)] = kGridFree;
      grid.start_made_free = true;
    }
  }
  return grid;
}

OccupancyGrid ProjectToGrid(const OccupancyMap& map, const FloorPlane& floor,
                            const GridOptions& options) {
  GridSources sources;
  sources.map = &map;
  sources.floor = floor;
  sources.world_from_grid = FloorFrame(floor, Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitX());
  return ProjectToGrid(sources, options);
}

GridQuality EvaluateGrid(const OccupancyGrid& grid,
                         const std::vector<Eigen::Vector3d>& static_points_in_world,
                         const std::vector<Eigen::Vector3d>& moving_positions_in_world,
                         double path_margin_m) {
  GridQuality quality;
  quality.path_margin_m = path_margin_m;
  const size_t width = static_cast<size_t>(grid.width), height = static_cast<size_t>(grid.height);
  std::vector<std::uint8_t> truth(width * height, 0);
  const Eigen::Isometry3d grid_from_world = grid.world_from_grid.inverse();
  for (const Eigen::Vector3d& point : static_points_in_world) {
    const Eigen::Vector3d g = grid_from_world * point;
    if (g.z() < grid.min_height || g.z() > grid.max_height) continue;
    const std::optional<Eigen::Vector2i> cell = grid.CellAtGridPoint(g.x(), g.y());
    if (cell) truth[grid.Index(*cell)] = 1;
  }
  // The moving objects' positions across the floor, in grid metres.
  std::vector<Eigen::Vector2d> paths;
  paths.reserve(moving_positions_in_world.size());
  for (const Eigen::Vector3d& position : moving_positions_in_world) {
    paths.push_back((grid_from_world * position).head<2>());
  }
  auto on_path = [&](int i, int j) {
    const Eigen::Vector2d centre(grid.origin.x() + (i + 0.5) * grid.resolution,
                                 grid.origin.y() + (j + 0.5) * grid.resolution);
    for (const Eigen::Vector2d& p : paths) {
      if ((p - centre).squaredNorm() <= path_margin_m * path_margin_m) return true;
    }
    return false;
  };
  auto near = [&](int i, int j, auto&& is) {
    for (int dj = -1; dj <= 1; ++dj) {
      for (int di = -1; di <= 1; ++di) {
        const int a = i + di, b = j + dj;
        if (grid.Contains(a, b) && is(a, b)) return true;
      }
    }
    return false;
  };
  for (int j = 0; j < grid.height; ++j) {
    for (int i = 0; i < grid.width; ++i) {
      const std::int8_t value = grid.At(i, j);
      if (value == kGridUnknown) continue;
      const bool truly = truth[static_cast<size_t>(j) * width + static_cast<size_t>(i)] != 0;
      const bool occupied = value == kGridOccupied;
      ++quality.observed_cells;
      quality.agreeing_cells += occupied == truly ? 1 : 0;
      if (occupied) {
        ++quality.occupied_cells;
        const bool explained = near(i, j, [&](int a, int b) {
          return truth[static_cast<size_t>(b) * width + static_cast<size_t>(a)] != 0;
        });
        quality.false_occupied += explained ? 0 : 1;
        quality.false_occupied_on_paths += !explained && on_path(i, j) ? 1 : 0;
      } else if (truly) {
        const bool nearby =
            near(i, j, [&](int a, int b) { return grid.At(a, b) == kGridOccupied; });
        quality.missed_occupied += nearby ? 0 : 1;
      }
    }
  }
  quality.agreement = quality.observed_cells > 0 ? static_cast<double>(quality.agreeing_cells) /
                                                       static_cast<double>(quality.observed_cells)
                                                 : 0.0;
  return quality;
}

}  // namespace stillmap
