// The 2-D occupancy grid against a hand-made room with exact truth: a floor, a box standing on it
// (blocks), a cable lying on it (below the band: drivable), a shelf above the robot's height
// (passable), all seen from a camera whose world frame is tilted and turned against the room, as
// a tracked map's first-camera frame is. Also the files as ROS map_server reads them.
#include "stillmap/mapping/occupancy_grid.h"

#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <iostream>
#include <map>
#include <opencv2/imgcodecs.hpp>

#include "stillmap/io/error.h"
#include "test_util.h"

namespace stillmap {
namespace {

// Room frame: z up, floor z = 0. Points every 1 cm on each surface.
struct Room {
  std::vector<Eigen::Vector3d> points;
  void Rectangle(const Eigen::Vector3d& corner, const Eigen::Vector3d& a,
                 const Eigen::Vector3d& b) {
    const int na = static_cast<int>(a.norm() / 0.01), nb = static_cast<int>(b.norm() / 0.01);
    for (int i = 0; i <= na; ++i) {
      for (int j = 0; j <= nb; ++j) points.push_back(corner + a * i / na + b * j / nb);
    }
  }
};

Room MakeRoom() {
  Room room;
  using V = Eigen::Vector3d;
  room.Rectangle(V(-1.5, 0.5, 0.0), V(3.0, 0, 0), V(0, 3.0, 0));  // floor
  // A box 0.5 x 0.5 x 0.8 m at x 0.5..1.0, y 2.0..2.5: top and the four sides.
  room.Rectangle(V(0.5, 2.0, 0.8), V(0.5, 0, 0), V(0, 0.5, 0));
  room.Rectangle(V(0.5, 2.0, 0.0), V(0.5, 0, 0), V(0, 0, 0.8));
  room.Rectangle(V(0.5, 2.5, 0.0), V(0.5, 0, 0), V(0, 0, 0.8));
  room.Rectangle(V(0.5, 2.0, 0.0), V(0, 0.5, 0), V(0, 0, 0.8));
  room.Rectangle(V(1.0, 2.0, 0.0), V(0, 0.5, 0), V(0, 0, 0.8));
  // A cable 3 cm high across the floor at y = 1.5, x -1.0..0.0.
  room.Rectangle(V(-1.0, 1.5, 0.03), V(1.0, 0, 0), V(0, 0.03, 0));
  // A shelf board at 1.8 m over x -1.0..-0.5, y 2.0..2.4.
  room.Rectangle(V(-1.0, 2.0, 1.8), V(0.5, 0, 0), V(0, 0.4, 0));
  return room;
}

class OccupancyGridTest : public ::testing::Test {
 protected:
  void SetUp() override {
    // World = a camera frame (y down, z forward), pitched 20 degrees down and turned 30 degrees,
    // 1.2 m above the floor at the room's origin.
    Eigen::Matrix3d camera_axes;  // room_from_camera for a level camera looking along room +y
    camera_axes << 1, 0, 0, 0, 0, 1, 0, -1, 0;
    const Eigen::Matrix3d rotation = Eigen::AngleAxisd(0.52, Eigen::Vector3d::UnitZ()).matrix() *
                                     camera_axes *
                                     Eigen::AngleAxisd(-0.35, Eigen::Vector3d::UnitX()).matrix();
    room_from_world_.linear() = rotation;
    room_from_world_.translation() = Eigen::Vector3d(0.0, 0.0, 1.2);
    const Eigen::Isometry3d world_from_room = room_from_world_.inverse();
    for (const Eigen::Vector3d& p : MakeRoom().points) truth_.push_back(world_from_room * p);
    // Seen from three places along the room's x, 1.2 m up: per place, the nearest point in each
    // 0.3-degree direction bin (what a depth camera sees; the rest is hidden).
    for (double x : {-0.5, 0.0, 0.5}) {
      const Eigen::Vector3d origin = world_from_room * Eigen::Vector3d(x, 0.0, 1.2);
      std::map<std::pair<int, int>, Eigen::Vector3d> nearest;
      for (const Eigen::Vector3d& p : truth_) {
        const Eigen::Vector3d ray = room_from_world_.linear() * (p - origin);
        const double bin = 0.3 * M_PI / 180.0;
        const std::pair<int, int> key(
            static_cast<int>(std::floor(std::atan2(ray.y(), ray.x()) / bin)),
            static_cast<int>(std::floor(std::asin(ray.z() / ray.norm()) / bin)));
        const auto it = nearest.find(key);
        if (it == nearest.end() || (p - origin).norm() < (it->second - origin).norm()) {
          nearest[key] = p;
        }
      }
      std::vector<Eigen::Vector3f> scan;
      scan.reserve(nearest.size());
      for (const auto& [key, p] : nearest) scan.push_back(p.cast<float>());
      for (int k = 0; k < 2; ++k) map_.InsertScan(scan, origin.cast<float>());
      scans_.emplace_back(scan, origin.cast<float>());
    }
    // The cameras' mean up, 5 degrees off the truth (as a tilted hand-held camera gives it).
    cameras_up_ = world_from_room.linear() *
                  (Eigen::AngleAxisd(0.087, Eigen::Vector3d::UnitX()) * Eigen::Vector3d::UnitZ());
  }

  // A room point's grid cell value.
  std::int8_t CellAt(const OccupancyGrid& grid, double x, double y) const {
    const auto cell = grid.CellOf(room_from_world_.inverse() * Eigen::Vector3d(x, y, 0.0));
    return cell ? grid.At(cell->x(), cell->y()) : kGridUnknown;
  }

  // The scans inserted into map_ twice each, to build maps of other resolutions.
  OccupancyMap MapOf(double resolution) const {
    OccupancyMapOptions options;
    options.resolution = resolution;
    OccupancyMap map(options);
    for (const auto& [scan, origin] : scans_) {
      for (int k = 0; k < 2; ++k) map.InsertScan(scan, origin);
    }
    return map;
  }
  // The truth as a voxel cloud (what the cleaned map holds).
  std::vector<VoxelPoint> TruthCloud() const {
    std::vector<VoxelPoint> cloud;
    for (const Eigen::Vector3d& p : truth_) cloud.push_back({p.cast<float>(), {0, 0, 0}, 1});
    return cloud;
  }
  // Occupied cells without a truth point above min_height over them.
  size_t PhantomCells(const OccupancyGrid& grid) const {
    std::vector<bool> high(grid.cells.size(), false);
    for (const Eigen::Vector3d& p : truth_) {
      const auto cell = grid.CellOf(p);
      if (cell && grid.floor.Height(p) > grid.min_height) {
        high[grid.Index(*cell)] = true;
      }
    }
    size_t phantoms = 0;
    for (size_t k = 0; k < grid.cells.size(); ++k) {
      phantoms += grid.cells[k] == kGridOccupied && !high[k] ? 1 : 0;
    }
    return phantoms;
  }

  Eigen::Isometry3d room_from_world_ = Eigen::Isometry3d::Identity();
  std::vector<Eigen::Vector3d> truth_;
  std::vector<std::pair<std::vector<Eigen::Vector3f>, Eigen::Vector3f>> scans_;
  OccupancyMap map_;
  Eigen::Vector3d cameras_up_;
};

TEST_F(OccupancyGridTest, FindsTheFloorAndProjectsTheBand) {
  const GridOptions options;
  const FloorPlane floor = FindFloor(map_, cameras_up_, options);
  EXPECT_EQ(floor.source, "fitted");
  const Eigen::Vector3d true_up = room_from_world_.linear().transpose() * Eigen::Vector3d::UnitZ();
  EXPECT_LT(std::acos(std::min(1.0, floor.up.dot(true_up))) * 180.0 / M_PI, 1.0);
  EXPECT_NEAR(floor.offset, 1.2, 0.03);  // the world origin (the camera) is 1.2 m up
  EXPECT_NEAR(floor.tilt_to_cameras_deg, 5.0, 1.0);

  const OccupancyGrid grid = ProjectToGrid(map_, floor, options);
  EXPECT_EQ(CellAt(grid, 0.75, 2.25), kGridOccupied);  // the box
  EXPECT_EQ(CellAt(grid, 0.0, 1.0), kGridFree);        // open floor
  EXPECT_EQ(CellAt(grid, -0.5, 1.51), kGridFree);      // the cable, below min_height
  EXPECT_EQ(CellAt(grid, -0.75, 2.2), kGridFree);      // under the shelf, above max_height
  EXPECT_EQ(CellAt(grid, 0.75, 2.45), kGridOccupied);  // the box's far edge
  EXPECT_EQ(CellAt(grid, 0.75, 2.9), kGridUnknown);    // hidden behind the box

  const GridQuality quality = EvaluateGrid(grid, truth_);
  EXPECT_GE(quality.agreement, 0.97);
  EXPECT_EQ(quality.false_occupied, 0u);
  EXPECT_EQ(quality.missed_occupied, 0u);

  // Against a truth without the box, the box's cells are occupied without static truth; they
  // count as on a moving object's path when one stood at the box, not when it passed 2 m away.
  std::vector<Eigen::Vector3d> without_box;
  for (const Eigen::Vector3d& p : truth_) {
    const Eigen::Vector3d r = room_from_world_ * p;
    const bool in_box =
        r.x() > 0.45 && r.x() < 1.05 && r.y() > 1.95 && r.y() < 2.55 && r.z() > 0.05;
    if (!in_box) without_box.push_back(p);
  }
  const Eigen::Isometry3d world_from_room = room_from_world_.inverse();
  const std::vector<Eigen::Vector3d> at_box = {world_from_room * Eigen::Vector3d(0.75, 2.25, 0.0)};
  const std::vector<Eigen::Vector3d> far_away = {world_from_room * Eigen::Vector3d(-1.0, 0.5, 0.0)};
  const GridQuality stood_there = EvaluateGrid(grid, without_box, at_box);
  EXPECT_GT(stood_there.false_occupied, 4u);  // the box is 10 x 10 cells; its outline at least
  EXPECT_EQ(stood_there.false_occupied_on_paths, stood_there.false_occupied);
  const GridQuality passed_by = EvaluateGrid(grid, without_box, far_away);
  EXPECT_EQ(passed_by.false_occupied, stood_there.false_occupied);
  EXPECT_EQ(passed_by.false_occupied_on_paths, 0u);

  // A given floor is used as given; a lower band then lets the cable block.
  GridOptions given = options;
  given.floor = Eigen::Vector4d(true_up.x(), true_up.y(), true_up.z(), 1.2);
  given.min_height = 0.02;
  const FloorPlane stated = FindFloor(map_, cameras_up_, given);
  // On its own (no configuration registered its keys) a component names a field by its own key.
  EXPECT_EQ(stated.source, "given (floor)");
  EXPECT_EQ(CellAt(ProjectToGrid(map_, stated, given), -0.5, 1.51), kGridOccupied);
}

// A remnant hit once (as the edge of a person a mask missed is, where no later ray passes)
// standing alone becomes unknown; the same once-hit voxels touching confirmed structure (in the
// box's shadow, against its top) stay occupied; with the hysteresis off, both are occupied.
TEST_F(OccupancyGridTest, WeaklyHitCellsNeedConfirmedNeighbours) {
  const Eigen::Isometry3d world_from_room = room_from_world_.inverse();
  std::vector<Eigen::Vector3f> remnant, ledge;
  for (int i = 0; i < 5; ++i) {
    for (int k = 0; k < 20; ++k) {
      remnant.push_back(
          (world_from_room * Eigen::Vector3d(-2.0 + 0.01 * i, 2.0, 0.2 + 0.02 * k)).cast<float>());
      ledge.push_back(
          (world_from_room * Eigen::Vector3d(0.75, 2.52 + 0.01 * i, 0.2 + 0.02 * k)).cast<float>());
    }
  }
  std::vector<Eigen::Vector3f> once = remnant;
  once.insert(once.end(), ledge.begin(), ledge.end());
  map_.InsertScan(once, (world_from_room * Eigen::Vector3d(0.0, 0.0, 1.2)).cast<float>());

  GridOptions options;
  const FloorPlane floor = FindFloor(map_, cameras_up_, options);
  const OccupancyGrid grid = ProjectToGrid(map_, floor, options);
  EXPECT_EQ(CellAt(grid, -1.98, 2.0), kGridUnknown);
  // The ledge (y 2.52 to 2.56) falls in the tilted OctoMap's voxels up to y 2.6.
  EXPECT_EQ(CellAt(grid, 0.75, 2.58), kGridOccupied);
  EXPECT_EQ(CellAt(grid, 0.75, 2.25), kGridOccupied);  // the box itself, seen six times
  EXPECT_GT(grid.unconfirmed_cells, 0u);

  options.confirm_probability = 0.5;  // off
  const OccupancyGrid plain = ProjectToGrid(map_, floor, options);
  EXPECT_EQ(CellAt(plain, -1.98, 2.0), kGridOccupied);
  EXPECT_EQ(plain.unconfirmed_cells, 0u);
}

// A coarse OctoMap in a tilted frame: its floor voxels reach into the band (10 cm voxels at 20
// degrees span up to 8 cm above their centres), so the OctoMap alone blocks bare floor. With the
// cloud, a cell is occupied only where points lie in the band: no phantom, the box kept.
TEST_F(OccupancyGridTest, TheCloudKeepsBareFloorOutOfTheObstacles) {
  const OccupancyMap coarse = MapOf(0.10);
  GridOptions options;
  GridSources sources;
  sources.map = &coarse;
  sources.floor = FindFloor(coarse, cameras_up_, options);
  sources.world_from_grid =
      FloorFrame(sources.floor, Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitX());
  options.min_cloud_points = 0;
  const OccupancyGrid alone = ProjectToGrid(sources, options);
  const std::vector<VoxelPoint> cloud = TruthCloud();
  sources.cloud = &cloud;
  options.min_cloud_points = 2;
  const OccupancyGrid checked = ProjectToGrid(sources, options);
  std::cout << "coarse tilted OctoMap: " << alone.Count(kGridOccupied) << " occupied cells, "
            << PhantomCells(alone) << " without points above the floor; with the cloud "
            << checked.Count(kGridOccupied) << " and " << PhantomCells(checked) << "\n";
  EXPECT_GT(PhantomCells(alone), 0u);
  EXPECT_EQ(PhantomCells(checked), 0u);
  EXPECT_GT(checked.unsupported_cells, 0u);
  EXPECT_EQ(CellAt(checked, 0.75, 2.25), kGridOccupied);  // the box
  EXPECT_EQ(CellAt(checked, 0.0, 1.0), kGridFree);        // open floor
}

// grid.resolution is the cell size, whatever the OctoMap's voxels: 10 cm cells over 5 cm voxels
// see the same room.
TEST_F(OccupancyGridTest, TheCellSizeIsTheGridsOwn) {
  GridOptions options;
  options.resolution = 0.10;
  const OccupancyGrid grid = ProjectToGrid(map_, FindFloor(map_, cameras_up_, options), options);
  EXPECT_DOUBLE_EQ(grid.resolution, 0.10);
  EXPECT_EQ(CellAt(grid, 0.75, 2.25), kGridOccupied);
  EXPECT_EQ(CellAt(grid, 0.0, 1.0), kGridFree);
  EXPECT_EQ(CellAt(grid, -0.75, 2.2), kGridFree);
  EXPECT_EQ(EvaluateGrid(grid, truth_).false_occupied, 0u);
}

// The floor frame: z the floor's up, the origin on the floor under the given point, x along the
// given direction projected onto the floor.
TEST_F(OccupancyGridTest, TheFloorFrameStandsUnderTheCamera) {
  const Eigen::Isometry3d world_from_room = room_from_world_.inverse();
  FloorPlane floor;  // the room's floor, exactly
  floor.up = world_from_room.linear() * Eigen::Vector3d::UnitZ();
  floor.offset = -floor.up.dot(world_from_room.translation());
  const Eigen::Vector3d camera = world_from_room * Eigen::Vector3d(0.3, 0.2, 1.2);
  const Eigen::Vector3d view = world_from_room.linear() * Eigen::Vector3d(0.0, 0.94, -0.34);
  const Eigen::Isometry3d frame = FloorFrame(floor, camera, view);
  const Eigen::Vector3d origin = room_from_world_ * frame.translation();
  EXPECT_NEAR(origin.x(), 0.3, 1e-9);
  EXPECT_NEAR(origin.y(), 0.2, 1e-9);
  EXPECT_NEAR(origin.z(), 0.0, 1e-9);
  const Eigen::Vector3d x = room_from_world_.linear() * frame.linear().col(0);
  const Eigen::Vector3d z = room_from_world_.linear() * frame.linear().col(2);
  EXPECT_GT(x.y(), 0.999);  // the view along room +y, projected
  EXPECT_GT(z.z(), 0.999);
  EXPECT_NEAR(frame.linear().determinant(), 1.0, 1e-9);
}

// The cell under the first camera is free: the camera stood there, and the floor right under it
// is never in view. A camera held over the box leaves its cell occupied.
TEST_F(OccupancyGridTest, TheStartCellIsFree) {
  const GridOptions options;
  GridSources sources;
  sources.map = &map_;
  sources.floor = FindFloor(map_, cameras_up_, options);
  const Eigen::Isometry3d world_from_room = room_from_world_.inverse();
  // Over the room's origin the floor is out of every view (the cameras look down 20 degrees).
  sources.start = world_from_room * Eigen::Vector3d(0.0, 0.0, 1.2);
  sources.world_from_grid = FloorFrame(sources.floor, *sources.start,
                                       world_from_room.linear() * Eigen::Vector3d::UnitY());
  const OccupancyGrid without = ProjectToGrid(map_, sources.floor, options);
  EXPECT_EQ(CellAt(without, 0.0, 0.0), kGridUnknown);
  const OccupancyGrid grid = ProjectToGrid(sources, options);
  EXPECT_TRUE(grid.start_made_free);
  EXPECT_EQ(CellAt(grid, 0.0, 0.0), kGridFree);
  // The grid frame's origin, under the camera, is a cell's centre (not a corner of four).
  const Eigen::Vector2i start = *grid.CellOf(*sources.start);
  EXPECT_NEAR(grid.origin.x() + (start.x() + 0.5) * grid.resolution, 0.0, 1e-9);
  EXPECT_NEAR(grid.origin.y() + (start.y() + 0.5) * grid.resolution, 0.0, 1e-9);
  sources.start = world_from_room * Eigen::Vector3d(0.75, 2.25, 1.2);
  EXPECT_EQ(CellAt(ProjectToGrid(sources, options), 0.75, 2.25), kGridOccupied);
}

// A quarter turn computed in floating point has 6e-17 where its entries are 0: grid.yaml says 0.
TEST_F(OccupancyGridTest, WorldFromMapHoldsNoRoundingNoise) {
  const GridOptions options;
  OccupancyGrid grid = ProjectToGrid(map_, FindFloor(map_, cameras_up_, options), options);
  grid.world_from_grid = Eigen::Isometry3d(Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()));
  testing::TempDir dir;
  WriteGrid(grid, dir / "grid.pgm", dir / "grid.yaml", "grid.pgm");
  const auto values = YAML::LoadFile(dir / "grid.yaml")["world_from_map"].as<std::vector<double>>();
  ASSERT_EQ(values.size(), 16u);
  for (const double value : values) {
    EXPECT_TRUE(value == 0.0 || value == 1.0 || value == -1.0) << value;
  }
}

// The files as map_server (ROS 1 and Nav2) reads them: the YAML keys, and each pixel's value
// giving the cell's state through occ = (255 - p) / 255 against the thresholds, with the image's
// bottom-left pixel at `origin`.
TEST_F(OccupancyGridTest, FilesReadAsMapServerReadsThem) {
  const GridOptions options;
  const OccupancyGrid grid = ProjectToGrid(map_, FindFloor(map_, cameras_up_, options), options);
  testing::TempDir dir;
  WriteGrid(grid, dir / "grid.pgm", dir / "grid.yaml", "grid.pgm");
  const YAML::Node yaml = YAML::LoadFile(dir / "grid.yaml");
  EXPECT_EQ(yaml["image"].as<std::string>(), "grid.pgm");
  const double resolution = yaml["resolution"].as<double>();
  EXPECT_DOUBLE_EQ(resolution, grid.resolution);
  const auto origin = yaml["origin"].as<std::vector<double>>();
  ASSERT_EQ(origin.size(), 3u);
  EXPECT_EQ(origin[2], 0.0);
  EXPECT_EQ(yaml["negate"].as<int>(), 0);
  const double occupied_thresh = yaml["occupied_thresh"].as<double>();
  const double free_thresh = yaml["free_thresh"].as<double>();
  EXPECT_EQ(yaml["mode"].as<std::string>(), "trinary");
  const auto world_from_map = yaml["world_from_map"].as<std::vector<double>>();
  ASSERT_EQ(world_from_map.size(), 16u);
  Eigen::Matrix4d m;
  for (int k = 0; k < 16; ++k) m(k / 4, k % 4) = world_from_map[static_cast<size_t>(k)];

  const cv::Mat image = cv::imread(dir / "grid.pgm", cv::IMREAD_UNCHANGED);
  ASSERT_EQ(image.type(), CV_8UC1);
  ASSERT_EQ(image.cols, grid.width);
  ASSERT_EQ(image.rows, grid.height);
  size_t occupied = 0, free = 0, unknown = 0;
  for (int row = 0; row < image.rows; ++row) {
    for (int col = 0; col < image.cols; ++col) {
      const double occ = (255.0 - image.at<std::uint8_t>(row, col)) / 255.0;
      const std::int8_t value = grid.At(col, image.rows - 1 - row);
      if (occ > occupied_thresh) {
        ++occupied;
        EXPECT_EQ(value, kGridOccupied);
      } else if (occ < free_thresh) {
        ++free;
        EXPECT_EQ(value, kGridFree);
      } else {
        ++unknown;
        EXPECT_EQ(value, kGridUnknown);
      }
    }
  }
  EXPECT_GT(occupied, 50u);
  EXPECT_GT(free, 1000u);
  EXPECT_GT(unknown, 10u);
  // The box's centre, through the YAML alone: room -> world -> map -> pixel.
  const Eigen::Vector4d box(0.75, 2.25, 0.4, 1.0);
  const Eigen::Vector4d in_world = room_from_world_.inverse().matrix() * box;
  const Eigen::Vector4d in_map = m.inverse() * in_world;
  EXPECT_NEAR(in_map.z(), 0.4, 0.03);  // map z is the height above the floor
  const int col = static_cast<int>(std::floor((in_map.x() - origin[0]) / resolution));
  const int row =
      image.rows - 1 - static_cast<int>(std::floor((in_map.y() - origin[1]) / resolution));
  EXPECT_EQ(image.at<std::uint8_t>(row, col), 0);

  // A planner on the loaded grid (A*, 8-connected, free cells only) gets from one side of the box
  // to the other, around it: no cell of its path lies on the box or off the free space.
  std::vector<bool> passable(static_cast<size_t>(image.rows * image.cols));
  for (int r = 0; r < image.rows; ++r) {
    for (int c = 0; c < image.cols; ++c) {
      passable[static_cast<size_t>(r) * static_cast<size_t>(image.cols) + static_cast<size_t>(c)] =
          (255.0 - image.at<std::uint8_t>(r, c)) / 255.0 < free_thresh;
    }
  }
  auto pixel_of = [&](double x, double y) {  // a room point's pixel, through the YAML alone
    const Eigen::Vector4d p =
        m.inverse() * (room_from_world_.inverse().matrix() * Eigen::Vector4d(x, y, 0.0, 1.0));
    return cv::Point(
        static_cast<int>(std::floor((p.x() - origin[0]) / resolution)),
        image.rows - 1 - static_cast<int>(std::floor((p.y() - origin[1]) / resolution)));
  };
  const std::vector<cv::Point> path =
      testing::PlanPath(passable, image.cols, image.rows, pixel_of(0.2, 2.25), pixel_of(1.3, 2.25));
  ASSERT_GT(path.size(), 10u) << "no path between two free cells either side of the box";
  const Eigen::Matrix4d room_from_map = room_from_world_.matrix() * m;
  for (const cv::Point& pixel : path) {
    ASSERT_TRUE(passable[static_cast<size_t>(pixel.y * image.cols + pixel.x)]);
    const Eigen::Vector4d centre =
        room_from_map * Eigen::Vector4d(origin[0] + (pixel.x + 0.5) * resolution,
                                        origin[1] + (image.rows - 1 - pixel.y + 0.5) * resolution,
                                        0.0, 1.0);
    const bool on_box =
        centre.x() > 0.5 && centre.x() < 1.0 && centre.y() > 2.0 && centre.y() < 2.5;
    EXPECT_FALSE(on_box) << centre.transpose();
  }
}

TEST(OccupancyGridCellsTest, CellsAtTheGridsEdgesAreInsideAndOneBeyondAreNot) {
  OccupancyGrid grid;
  grid.width = 3;
  grid.height = 2;
  grid.resolution = 0.5;
  grid.origin = Eigen::Vector2d(-1.0, 2.0);
  EXPECT_TRUE(grid.Contains(0, 0));
  EXPECT_TRUE(grid.Contains(2, 1));
  EXPECT_FALSE(grid.Contains(3, 1));
  EXPECT_FALSE(grid.Contains(2, 2));
  EXPECT_FALSE(grid.Contains(-1, 0));
  EXPECT_FALSE(grid.Contains(0, -1));
  // The grid spans x in [-1, 0.5) and y in [2, 3) metres.
  ASSERT_TRUE(grid.CellAtGridPoint(0.49, 2.99));
  EXPECT_EQ(*grid.CellAtGridPoint(0.49, 2.99), Eigen::Vector2i(2, 1));
  EXPECT_FALSE(grid.CellAtGridPoint(0.5, 2.5));
  EXPECT_FALSE(grid.CellAtGridPoint(-1.01, 2.5));
  EXPECT_FALSE(grid.CellAtGridPoint(0.0, 3.0));
}

TEST(GridOptionsTest, ImpossibleValuesAreRejectedByName) {
  GridOptions low;
  low.max_height = 0.05;
  EXPECT_THROW(low.Validate(), InputError);
  GridOptions flat;
  flat.floor = Eigen::Vector4d(0, 0, 0, 1);
  try {
    flat.Validate();
    FAIL() << "a zero normal was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("floor:"), std::string::npos);  // its own key
  }
}

}  // namespace
}  // namespace stillmap
