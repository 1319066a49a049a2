// The grid's surface-spill rule (GridOptions::surface_spill_m) against a scene with exact truth:
// a wall whose surface lies 7 mm inside a cell, its points scattered across it as depth noise
// scatters them (one in a hundred 8 mm out, over the cell's edge), and a thin board standing
// right on the edge between two cells. The
// OctoMap's voxels straddle the cell edges, so it marks the cell beside the wall occupied too;
// the cloud's points show that cell holds only a few strays near its edge.
#include <gtest/gtest.h>

#include <vector>

#include "stillmap/io/error.h"
#include "stillmap/mapping/occupancy_grid.h"

namespace stillmap {
namespace {

constexpr double kWallX = 0.018;   // the wall's surface [m]; its cell spans -0.025..0.025
constexpr double kBoardX = 0.525;  // the board: right on the edge of the cells 10 and 11
constexpr double kHeight = 1.0;    // both stand 1 m tall

// A vertical rectangle x = x0 over y0..y1, 0..kHeight, its points every 1 cm with x scattered:
// -6..+6 mm in 1 mm steps, and one point in a hundred 8 mm out on either side.
struct Panel {
  double x0, y0, y1;
  void AddPoints(std::vector<Eigen::Vector3d>* points) const {
    int k = 0;
    for (double y = y0; y <= y1 + 1e-9; y += 0.01) {
      for (double z = 0.0; z <= kHeight + 1e-9; z += 0.01, ++k) {
        const double scatter = k % 100 == 0 ? 0.008 : k % 100 == 50 ? -0.008 : 0.001 * (k % 13 - 6);
        points->emplace_back(x0 + scatter, y, z);
      }
    }
  }
  // Whether the panel hides `p` from `eye`.
  bool Hides(const Eigen::Vector3d& eye, const Eigen::Vector3d& p) const {
    if ((eye.x() - x0) * (p.x() - x0) >= 0.0) return false;
    const double t = (x0 - eye.x()) / (p.x() - eye.x());
    const Eigen::Vector3d crossing = eye + t * (p - eye);
    return crossing.y() >= y0 && crossing.y() <= y1 && crossing.z() <= kHeight;
  }
};

class GridSurfaceSpillTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const Panel wall{kWallX, -0.9, -0.3}, board{kBoardX, 0.3, 0.9};
    wall.AddPoints(&points_);
    board.AddPoints(&points_);
    const Eigen::Vector3d eye(-0.8, 0.0, 0.6);
    for (double x = -1.0; x <= 1.0 + 1e-9; x += 0.01) {
      for (double y = -1.0; y <= 1.0 + 1e-9; y += 0.01) {
        const Eigen::Vector3d p(x, y, 0.0);
        if (!wall.Hides(eye, p) && !board.Hides(eye, p)) points_.push_back(p);
      }
    }
    OccupancyMapOptions map_options;
    map_options.resolution = 0.02;
    map_ = OccupancyMap(map_options);
    std::vector<Eigen::Vector3f> scan;
    for (const Eigen::Vector3d& p : points_) {
      scan.push_back(p.cast<float>());
      cloud_.push_back({p.cast<float>(), {0, 0, 0}, 1});
    }
    for (int k = 0; k < 2; ++k) map_.InsertScan(scan, eye.cast<float>());
  }

  // The defaults, or with the spill rule off.
  OccupancyGrid Grid(bool spill_rule) const {
    GridOptions options;
    if (!spill_rule) options.surface_spill_m = 0.0;
    GridSources sources;
    sources.map = &map_;
    sources.cloud = &cloud_;  // world = the grid frame: the floor is z = 0
    return ProjectToGrid(sources, options);
  }
  static std::int8_t At(const OccupancyGrid& grid, double x, double y) {
    const auto cell = grid.CellAtGridPoint(x, y);
    return cell ? grid.At(cell->x(), cell->y()) : kGridUnknown;
  }

  std::vector<Eigen::Vector3d> points_;
  std::vector<VoxelPoint> cloud_;
  OccupancyMap map_;
};

TEST_F(GridSurfaceSpillTest, TheCellBesideAWallHoldsOnlyItsStrays) {
  const OccupancyGrid off = Grid(false), on = Grid(true);
  size_t rows = 0;
  for (double y = -0.85; y <= -0.35; y += 0.05, ++rows) {
    EXPECT_EQ(At(off, 0.0, y), kGridOccupied) << y;  // the wall's own cell
    EXPECT_EQ(At(on, 0.0, y), kGridOccupied) << y;
    EXPECT_EQ(At(off, 0.05, y), kGridOccupied) << y;  // the wall one cell too thick
    EXPECT_NE(At(on, 0.05, y), kGridOccupied) << y;
  }
  EXPECT_GE(on.spilled_cells, rows);
  EXPECT_EQ(off.spilled_cells, 0u);
}

// A thin board on a cell edge puts as many points on either side: both cells are the board.
TEST_F(GridSurfaceSpillTest, AThinSurfaceOnAnEdgeKeepsBothCells) {
  const OccupancyGrid on = Grid(true);
  for (double y = 0.35; y <= 0.85; y += 0.05) {
    EXPECT_EQ(At(on, 0.5, y), kGridOccupied) << y;
    EXPECT_EQ(At(on, 0.55, y), kGridOccupied) << y;
  }
}

// The truth (the noiseless surfaces) agrees better with the rule than without.
TEST_F(GridSurfaceSpillTest, AgreementWithTheTruthRises) {
  std::vector<Eigen::Vector3d> truth;
  Panel{kWallX, -0.9, -0.3}.AddPoints(&truth);
  Panel{kBoardX, 0.3, 0.9}.AddPoints(&truth);
  for (Eigen::Vector3d& p : truth) {
    p.x() = p.x() < 0.3 ? kWallX : kBoardX;  // no scatter
  }
  const GridQuality off = EvaluateGrid(Grid(false), truth), on = EvaluateGrid(Grid(true), truth);
  EXPECT_GT(on.agreement, off.agreement);
  EXPECT_LT(on.occupied_cells, off.occupied_cells);
  EXPECT_EQ(on.missed_occupied, 0u);
}

TEST(GridSurfaceSpillOptionsTest, ImpossibleValuesAreRejected) {
  GridOptions options;
  options.surface_spill_m = -0.01;
  EXPECT_THROW(options.Validate(), InputError);
  options.surface_spill_m = 0.1;  // beyond half a cell: half a cell
  EXPECT_NO_THROW(options.Validate());
  options.surface_spill_ratio = 0.5;
  EXPECT_THROW(options.Validate(), InputError);
}

}  // namespace
}  // namespace stillmap
