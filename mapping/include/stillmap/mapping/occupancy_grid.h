// The 2-D occupancy grid for navigation planners: the OctoMap projected over a height band above
// the floor, written as the ROS map_server pair grid.pgm + grid.yaml.
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "stillmap/io/cloud_files.h"
#include "stillmap/mapping/occupancy_map.h"

namespace stillmap {

struct GridOptions {
  bool enabled = true;
  // The band above the floor that the robot occupies [m]: an occupied voxel in it blocks the
  // cell. Below min_height lie the floor itself and what a robot drives over; above max_height,
  // what it passes under.
  double min_height = 0.10;
  double max_height = 1.50;
  // The cell edge [m], independent of the OctoMap's voxels (each cell's column is sampled at
  // the OctoMap's resolution).
  double resolution = 0.05;
  // An occupied OctoMap voxel in the band blocks its cell only when the cleaned voxel cloud holds
  // at least this many points in the band over the cell: a floor voxel of a coarse, tilted
  // OctoMap reaches into the band with nothing above the floor. Cells that fail it are free
  // when the cloud shows the floor there, else unknown. 0: the OctoMap alone decides.
  int min_cloud_points = 2;
  // Surface spill: an occupied cell whose band points (of the cleaned cloud) all lie within
  // surface_spill_m (at most half a cell) of one edge, with an occupied neighbour across it that
  // holds at least surface_spill_ratio times as many, is that neighbour's surface scattered over
  // the edge by depth noise and pose error (walls one cell thicker than they are): free when the
  // cloud shows the floor there, else unknown. 0: off.
  double surface_spill_m = 0.025;
  double surface_spill_ratio = 64.0;
  // Unseen layers (band_coverage.h): a free cell becomes unknown where the fused keyframes' rays
  // left a layer of the band at least this thick uncrossed between layers they crossed, which is
  // what a flat top seen only edge-on leaves (a table's 4 cm top from a camera 16 cm above it)
  // [m]; 0: off. The rays are cast from every unseen_layer_block_step-th block of the keyframes'
  // grid views (Mapper's keep_grid_views: 4 x 4 pixel blocks), across and down. 3 cm: a table's
  // top is 2-5 cm thick, and thinner layers are the gaps a fan of rays leaves between its rays.
  double min_unseen_layer_m = 0.03;
  int unseen_layer_block_step = 1;
  // Unseen layers: a keyframe counts a layer over a cell as missed only where it sees that layer
  // within this angle of its camera's level [deg], where a flat top would return nothing: depth
  // sensors lose their readings near grazing incidence (the synthetic sensor gives none beyond
  // cos 0.17, 80 degrees). Layers it looks at more steeply and missed are patches the sensor
  // returned nothing for (dark or distant surfaces). 90: every layer.
  double unseen_layer_grazing_deg = 10.0;
  // The floor plane in the map's world frame, n.x + d = 0 with n pointing up, when given
  // (grid.floor "a b c d"); otherwise fitted to the map.
  std::optional<Eigen::Vector4d> floor;
  // A voxel blocks its cell when its occupancy probability exceeds this (OctoMap's own
  // threshold is 0.5: one hit in a fresh voxel gives 0.7, a second 0.84). Higher removes
  // remnants of people but frees true obstacles, the worse error for a planner.
  double occupied_probability = 0.5;
  // Hysteresis: occupied cells stay occupied only when connected to a cell whose voxels exceed
  // this (hit at least twice more than missed); the others become unknown. <= occupied_probability:
  // off.
  double confirm_probability = 0.8;
  // A fitted floor's normal must lie within this angle of the cameras' mean up direction.
  double max_floor_tilt_deg = 30.0;
  // The floor fit (PCL RANSAC of planes perpendicular to the cameras' up, threshold one OctoMap
  // voxel): up to floor_ransac_rounds planes of floor_ransac_iterations samples each, while at
  // least floor_min_points voxels remain; a plane needs floor_min_points inliers and at least
  // floor_min_inliers_per_mille of the occupied voxels.
  int floor_ransac_rounds = 4;
  int floor_ransac_iterations = 500;
  int floor_min_points = 50;
  int floor_min_inliers_per_mille = 20;

  // Throws InputError naming the first impossible value.
  void Validate() const;

  // Every field under its configuration key (io/option_fields.h).
  template <typename Self, typename Visitor>
  static void VisitFields(Self& self, Visitor& visit) {
    visit("enabled", self.enabled, "write the 2-D occupancy grid (grid.pgm, grid.yaml)");
    visit("min_height", self.min_height, "lowest height above the floor that blocks a cell [m]");
    visit("max_height", self.max_height, "robot height: highest blocking height [m]");
    visit("resolution", self.resolution, "grid cell edge [m] (independent of octomap.resolution)");
    visit("min_cloud_points", self.min_cloud_points,
          "voxel-cloud points in the band a cell needs to be occupied (0: OctoMap alone)");
    visit("surface_spill_m", self.surface_spill_m,
          "an occupied cell whose band points all lie this near one edge (at most half a cell), "
          "with a much denser occupied neighbour across it, is that neighbour's surface spilled "
          "over [m] (0: off)");
    visit("surface_spill_ratio", self.surface_spill_ratio,
          "surface spill: how many times as many band points the neighbour holds");
    visit("min_unseen_layer_m", self.min_unseen_layer_m,
          "a free cell is unknown where the keyframes' rays left a layer of the band this thick "
          "uncrossed between layers they crossed, as a table's top seen only edge-on does [m] "
          "(0: off)");
    visit("unseen_layer_block_step", self.unseen_layer_block_step,
          "unseen layers: rays from every n-th 4 x 4 pixel block of the keyframes' depth");
    visit("unseen_layer_grazing_deg", self.unseen_layer_grazing_deg,
          "unseen layers: a keyframe counts a layer as missed only where it sees it within this "
          "angle of its camera's level, where a flat top returns no depth [deg] (90: every layer)");
    visit(
        "floor", self.floor,
        "auto (fit a plane to the map) or 'a b c d': the floor a x + b y + c z + d = 0 [m] in the "
        "poses' frame (the first camera's when tracking, groundtruth.txt's world with --poses "
        "groundtruth), (a, b, c) pointing up");
    visit("occupied_probability", self.occupied_probability,
          "a voxel blocks its grid cell above this occupancy probability");
    visit("confirm_probability", self.confirm_probability,
          "occupied cells stay occupied only when connected to one above this (else unknown)");
    visit("max_floor_tilt_deg", self.max_floor_tilt_deg,
          "a fitted floor's normal is within this of the cameras' up [deg]");
    visit("floor_ransac_rounds", self.floor_ransac_rounds, "floor fit: planes tried at most");
    visit("floor_ransac_iterations", self.floor_ransac_iterations,
          "floor fit: RANSAC samples per plane");
    visit("floor_min_points", self.floor_min_points, "floor fit: fewest inliers of a plane");
    visit("floor_min_inliers_per_mille", self.floor_min_inliers_per_mille,
          "floor fit: fewest inliers, per mille of the occupied voxels");
  }
};

struct FloorPlane {
  Eigen::Vector3d up = Eigen::Vector3d::UnitZ();  // unit normal, pointing away from the floor
  double offset = 0.0;                            // height above the floor = up.x + offset
  std::string source;                             // "fitted", "given", or the fallback used
  double tilt_to_cameras_deg = 0.0;               // angle between up and the cameras' mean up
  size_t inliers = 0;                             // occupied voxels on the fitted plane
  double Height(const Eigen::Vector3d& point) const { return up.dot(point) + offset; }
};

// The rotation from world to floor axes, rows x, y, up: x is the world x axis projected onto the
// floor (the world z axis when x points nearly up), y = up x x. The grid's and the renders' frame.
Eigen::Matrix3d FloorAxes(const Eigen::Vector3d& up);

// The frame on the floor: z = floor.up, origin = `above` projected onto the floor, x = `forward`
// projected onto the floor (FloorAxes' x when `forward` is within 25 degrees of vertical), y = z
// x x. The default map frame (with the first camera's centre and viewing direction) and the
// grid's frame.
Eigen::Isometry3d FloorFrame(const FloorPlane& floor, const Eigen::Vector3d& above,
                             const Eigen::Vector3d& forward);

// The sum of the cameras' up (-y) axes: a direction for FindFloor to check the floor against
// (zero for no cameras).
Eigen::Vector3d MeanCameraUp(const std::vector<Eigen::Isometry3d>& world_from_cameras);

// The floor: among near-horizontal planes (normal within max_floor_tilt_deg of `cameras_up`)
// found by RANSAC in the occupied voxels, the lowest that holds at least a quarter as many
// voxels as the largest. With no such plane, the 2nd percentile of the voxels' heights along
// `cameras_up` (source says so). `cameras_up`: the mean of the cameras' up (-y) axes.
FloorPlane FindFloor(const OccupancyMap& map, const Eigen::Vector3d& cameras_up,
                     const GridOptions& options);
// The same fit to a point cloud (a map without OctoMap), thinned to one point per `cell` [m]
// voxel, with `cell` as the plane threshold.
FloorPlane FindFloor(const std::vector<VoxelPoint>& cloud, double cell,
                     const Eigen::Vector3d& cameras_up, const GridOptions& options);

// A fitted floor moved onto the cloud's own floor points: four times, the points within `band`
// [m] of the plane (then band / 2, / 4, / 8: the narrowing band leaves walls and furniture out)
// give its normal (their principal axis, kept when within 5 degrees of the fit) and its height
// (their median). The OctoMap's voxel centres put a thick or tilted floor up to a voxel off; the
// cloud's finer points put z = 0 where the floor's points are. Given floors and the percentile
// fallback are returned as they are.
FloorPlane RefineFloor(const FloorPlane& floor, const std::vector<VoxelPoint>& cloud, double band);

// Cell values as ROS nav_msgs/OccupancyGrid has them.
constexpr std::int8_t kGridUnknown = -1;
constexpr std::int8_t kGridFree = 0;
constexpr std::int8_t kGridOccupied = 100;

struct OccupancyGrid {
  int width = 0;  // cells along the grid's x
  int height = 0;
  double resolution = 0.05;  // cell edge [m]
  // The grid frame (ROS's "map" frame for this grid), on the floor with z up (GridSources).
  // Cell (i, j) covers
  // x in origin.x + [i, i+1) * resolution, y in origin.y + [j, j+1) * resolution.
  Eigen::Isometry3d world_from_grid = Eigen::Isometry3d::Identity();
  Eigen::Vector2d origin = Eigen::Vector2d::Zero();  // lower-left corner of cell (0, 0) [m]
  std::vector<std::int8_t> cells;                    // row-major, j = 0 first (the lowest y)
  FloorPlane floor;
  double min_height = 0.0, max_height = 0.0;
  size_t unconfirmed_cells = 0;  // occupied but not connected to confirmed structure: unknown
  // Occupied in the OctoMap with fewer than min_cloud_points cloud points in the band: made free
  // (the cloud shows the floor there) or unknown.
  size_t unsupported_cells = 0;
  // Occupied only by a denser neighbour's surface spilled over their shared edge
  // (GridOptions::surface_spill_m): made free or unknown.
  size_t spilled_cells = 0;
  bool start_made_free = false;  // the cell under the first camera was unknown, now free
  // Free in the OctoMap, with a layer of the band no ray crossed (GridOptions::min_unseen_layer_m):
  // made unknown.
  size_t unseen_layer_cells = 0;

  // Whether cell (i, j) lies inside the grid.
  bool Contains(int i, int j) const { return i >= 0 && j >= 0 && i < width && j < height; }
  std::int8_t At(int i, int j) const {
    return cells[static_cast<size_t>(j) * static_cast<size_t>(width) + static_cast<size_t>(i)];
  }
  // The cell holding a world point's projection, or nothing outside the grid.
  std::optional<Eigen::Vector2i> CellOf(const Eigen::Vector3d& point_in_world) const;
  // The cell holding a point given in the grid frame (x, y [m]), or nothing outside the grid.
  std::optional<Eigen::Vector2i> CellAtGridPoint(double x, double y) const;
  // Its index in `cells`.
  size_t Index(const Eigen::Vector2i& cell) const {
    return static_cast<size_t>(cell.y()) * static_cast<size_t>(width) +
           static_cast<size_t>(cell.x());
  }
  size_t Count(std::int8_t value) const;
};

// What a grid is projected from.
struct GridSources {
  const OccupancyMap* map = nullptr;  // required
  FloorPlane floor;
  // The grid's frame in the world: z = floor.up, origin on the floor (FloorFrame).
  Eigen::Isometry3d world_from_grid = Eigen::Isometry3d::Identity();
  // The cleaned voxel cloud in the world frame, for GridOptions::min_cloud_points; null: the
  // OctoMap alone decides.
  const std::vector<VoxelPoint>* cloud = nullptr;
  // Where the first camera was: the cell under it is made free when it is unknown (the camera
  // stood there; the floor right under it is never in view).
  std::optional<Eigen::Vector3d> start;
};

// Occupied where an occupied voxel lies in the band (and the cloud holds min_cloud_points points
// in the band over the cell); free where nothing in the band is occupied and either the floor or
// the band's lowest voxels (up to two above min_height) were seen free; unknown elsewhere (space
// seen free only higher up, as in the shadow of a box, may hide a low obstacle). Each cell's
// column is looked up in the OctoMap at OctoMap-voxel spacing across the cell, every half voxel
// in height.
OccupancyGrid ProjectToGrid(const GridSources& sources, const GridOptions& options);
// The OctoMap alone, in FloorFrame(floor, world origin, world x axis), no start cell.
OccupancyGrid ProjectToGrid(const OccupancyMap& map, const FloorPlane& floor,
                            const GridOptions& options);

// grid.pgm (trinary: 0 occupied, 254 free, 205 unknown; the top row is the highest y) and
// grid.yaml (image, resolution, origin [x, y, yaw], negate, occupied_thresh, free_thresh, mode,
// and the grid's frame in the map's world frame). `image_name` is written into the YAML.
void WriteGrid(const OccupancyGrid& grid, const std::string& pgm_path, const std::string& yaml_path,
               const std::string& image_name);

// Reads back what WriteGrid wrote (grid.yaml and the image it names, beside it). Throws
// InputError naming the file and the missing or malformed key.
OccupancyGrid ReadGrid(const std::string& yaml_path);

// Agreement of a grid with occupancy computed the same way from ground-truth static points
// (in the same world frame): a cell is truly occupied when a point lies in the band over it.
struct GridQuality {
  size_t observed_cells = 0;   // free or occupied in the grid
  size_t agreeing_cells = 0;   // of those, occupied exactly where the truth is
  double agreement = 0.0;      // agreeing / observed
  size_t occupied_cells = 0;   // occupied in the grid
  size_t false_occupied = 0;   // occupied with no true occupied cell within one cell
  size_t missed_occupied = 0;  // observed free, truly occupied (no grid-occupied neighbour)
  // Of false_occupied, the cells whose centre lies within path_margin_m (across the floor) of
  // where a moving object was at some time: occupied because a person stood there.
  size_t false_occupied_on_paths = 0;
  double path_margin_m = 0.0;  // the margin used
};
// `moving_positions_in_world`: where moving objects were over time (e.g. objects.txt), or empty.
GridQuality EvaluateGrid(const OccupancyGrid& grid,
                         const std::vector<Eigen::Vector3d>& static_points_in_world,
                         const std::vector<Eigen::Vector3d>& moving_positions_in_world = {},
                         double path_margin_m = 0.5);

}  // namespace stillmap
