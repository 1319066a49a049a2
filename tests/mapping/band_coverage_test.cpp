// The grid's unseen layers (band_coverage.h) against a scene with exact truth, ray-traced here: a
// camera at a robot's 0.90 m looks along a floor at a wall 3 m away, over a table whose 4 cm top
// (0.72-0.76 m) it sees only edge-on. Like the synthetic sensor it returns nothing where a ray
// meets a surface within 10 degrees of grazing, so the top's upper face gives no reading and its
// front face does.
#include "stillmap/mapping/band_coverage.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>

#include "stillmap/io/camera.h"
#include "stillmap/io/error.h"
#include "stillmap/synth/synthetic.h"

namespace stillmap {
namespace {

constexpr double kEyeHeight = 0.90;
constexpr double kWallX = 3.0;
constexpr double kTableX0 = 1.2, kTableX1 = 2.0, kTableHalfY = 0.5;  // the top's extent [m]
constexpr double kTopBottom = 0.72, kTopTop = 0.76;
constexpr double kGrazingCos = 0.17;  // cos(80 degrees): nothing returns beyond it

// world_from_camera: at (0, 0, height), looking along +x pitched down by pitch_deg, image x to
// -y, image y down.
Eigen::Isometry3d WorldFromCamera(double height = kEyeHeight, double pitch_deg = 0.0) {
  const double pitch = pitch_deg * M_PI / 180.0;
  Eigen::Matrix3d axes;
  axes.col(0) = -Eigen::Vector3d::UnitY();
  axes.col(1) = Eigen::Vector3d(-std::sin(pitch), 0.0, -std::cos(pitch));
  axes.col(2) = Eigen::Vector3d(std::cos(pitch), 0.0, -std::sin(pitch));
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = axes;
  pose.translation() = Eigen::Vector3d(0.0, 0.0, height);
  return pose;
}

// The first surface a ray from `eye` along `dir` meets: its distance along dir and the cosine of
// its incidence; nothing when it leaves the room.
struct Hit {
  double t;
  double cos_incidence;
};
std::optional<Hit> Trace(const Eigen::Vector3d& eye, const Eigen::Vector3d& dir, bool table) {
  std::optional<Hit> best;
  auto consider = [&](double t, const Eigen::Vector3d& normal, auto&& inside) {
    if (!(t > 1e-9) || (best && t >= best->t) || !inside(eye + t * dir)) return;
    best = Hit{t, std::abs(normal.dot(dir))};
  };
  const auto always = [](const Eigen::Vector3d&) { return true; };
  if (dir.z() < 0.0) consider(-eye.z() / dir.z(), Eigen::Vector3d::UnitZ(), always);  // floor
  if (dir.x() > 0.0) consider((kWallX - eye.x()) / dir.x(), Eigen::Vector3d::UnitX(), always);
  if (!table) return best;
  const auto within_y = [](const Eigen::Vector3d& p) { return std::abs(p.y()) <= kTableHalfY; };
  if (dir.z() < 0.0) {  // the top's upper face
    consider((kTopTop - eye.z()) / dir.z(), Eigen::Vector3d::UnitZ(),
             [&](const Eigen::Vector3d& p) {
               return within_y(p) && p.x() >= kTableX0 && p.x() <= kTableX1;
             });
  }
  if (dir.x() > 0.0) {  // its front face
    consider((kTableX0 - eye.x()) / dir.x(), Eigen::Vector3d::UnitX(),
             [&](const Eigen::Vector3d& p) {
               return within_y(p) && p.z() >= kTopBottom && p.z() <= kTopTop;
             });
  }
  if (dir.z() > 0.0) {  // its lower face, seen from under it
    consider((kTopBottom - eye.z()) / dir.z(), Eigen::Vector3d::UnitZ(),
             [&](const Eigen::Vector3d& p) {
               return within_y(p) && p.x() >= kTableX0 && p.x() <= kTableX1;
             });
  }
  return best;
}

// The camera's view of the scene (with the table or without), image rows [first_row, last_row)
// only: the nearest reading of each 2 x 2 block, as the map keeps it.
KeyframeView RenderView(const Camera& camera, bool table = true, int first_row = 0,
                        int last_row = std::numeric_limits<int>::max(),
                        const Eigen::Isometry3d& world_from_camera = WorldFromCamera()) {
  cv::Mat depth_m(camera.height, camera.width, CV_32FC1, cv::Scalar(0.0f));
  for (int v = std::max(0, first_row); v < std::min(camera.height, last_row); ++v) {
    for (int u = 0; u < camera.width; ++u) {
      const Eigen::Vector3d ray((u - camera.cx) / camera.fx, (v - camera.cy) / camera.fy, 1.0);
      const Eigen::Vector3d dir = world_from_camera.linear() * ray.normalized();
      const std::optional<Hit> hit = Trace(world_from_camera.translation(), dir, table);
      if (!hit || hit->cos_incidence < kGrazingCos) continue;
      depth_m.at<float>(v, u) = static_cast<float>(hit->t / ray.norm());  // along the optical axis
    }
  }
  return MakeKeyframeView(depth_m, cv::Mat(), world_from_camera);
}

// A grid over the room, in the world frame (floor at z = 0), every cell free.
OccupancyGrid RoomGrid() {
  OccupancyGrid grid;
  grid.resolution = 0.05;
  grid.origin = Eigen::Vector2d(-0.5, -1.5);
  grid.width = 80;   // x -0.5..3.5
  grid.height = 60;  // y -1.5..1.5
  grid.min_height = 0.10;
  grid.max_height = 1.50;
  grid.cells.assign(static_cast<size_t>(grid.width) * static_cast<size_t>(grid.height), kGridFree);
  return grid;
}

class BandCoverageTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const Camera camera = SynthCamera();
    coverage_.AddView(RenderView(camera), PixelRays(camera), camera.width, 4.0, 1);
  }
  // The unseen layer over the cell holding (x, y) [m].
  double UnseenAt(double x, double y) const {
    const std::optional<Eigen::Vector2i> cell = grid_.CellAtGridPoint(x, y);
    EXPECT_TRUE(cell.has_value());
    return coverage_.UnseenLayer(cell->x(), cell->y());
  }
  OccupancyGrid grid_ = RoomGrid();
  BandCoverage coverage_{grid_, 0.01};
};

TEST_F(BandCoverageTest, ATopSeenOnlyEdgeOnIsALayerNoRayCrossed) {
  // Over the table's middle the rays under the top reach 0.66 m and those over it 0.79 m (each
  // through the top's near or far edge): 13 cm unseen, the top's 4 cm within it.
  EXPECT_GE(UnseenAt(1.62, 0.01), 0.10);
  EXPECT_LE(UnseenAt(1.62, 0.01), 0.16);
  EXPECT_GE(UnseenAt(1.22, 0.40), kTopTop - kTopBottom);  // its near corner
}

TEST_F(BandCoverageTest, InFrontOfTheTableOnlyTheRaysThatReturnNothingLeaveALayer) {
  // The rays that meet the top's upper face return nothing: in front of the table they span the
  // heights between the rays through its near and far top edges, a wedge that thins towards
  // the camera. Elsewhere every height is crossed.
  for (const double x : {0.42, 0.82, 1.12}) {
    const double wedge = (kEyeHeight - kTopTop) * x * (1.0 / kTableX0 - 1.0 / kTableX1);
    EXPECT_LE(UnseenAt(x, 0.01), wedge + 0.01) << "x " << x;
  }
  EXPECT_LT(UnseenAt(0.42, 0.01), 0.03);
  EXPECT_LT(UnseenAt(1.62, 0.82), 0.02) << "beside the table";
  EXPECT_LT(UnseenAt(0.82, -0.82), 0.02) << "beside the table";
}

TEST_F(BandCoverageTest, TheTopsShadowIsUnseenToo) {
  // Behind the table, rays under it reach 0.56 m and rays over it 0.74 m: the sensor cannot tell
  // the shadow from the top, and a planner should not be told either is free.
  EXPECT_GE(UnseenAt(2.32, 0.01), 0.15);
}

TEST_F(BandCoverageTest, FreeCellsWithAnUnseenLayerBecomeUnknown) {
  OccupancyGrid grid = grid_;
  const std::optional<Eigen::Vector2i> wall_cell = grid.CellAtGridPoint(kWallX + 0.01, 0.0);
  grid.cells[grid.Index(*wall_cell)] = kGridOccupied;
  const size_t changed = UnknownWhereLayersUnseen(coverage_, 0.03, &grid);
  EXPECT_GT(changed, 0u);
  EXPECT_EQ(grid.At(grid.CellAtGridPoint(1.62, 0.01)->x(), grid.CellAtGridPoint(1.62, 0.01)->y()),
            kGridUnknown);
  EXPECT_EQ(grid.At(grid.CellAtGridPoint(0.42, 0.01)->x(), grid.CellAtGridPoint(0.42, 0.01)->y()),
            kGridFree);
  EXPECT_EQ(grid.cells[grid.Index(*wall_cell)], kGridOccupied);  // only free cells change
  EXPECT_EQ(changed, grid.Count(kGridUnknown));
}

TEST(BandCoverageViewsTest, LayersBetweenTwoViewsFansAreNotAHole) {
  // The bare room seen twice, once by the image's upper rows only and once by its lower rows:
  // the heights the middle rows would have crossed were not looked at, and nothing hid them.
  // The same rows missing from one view (a person masked out, say) are a hole in its fan.
  const Camera camera = SynthCamera();
  const std::vector<Eigen::Vector2f> rays = PixelRays(camera);
  const OccupancyGrid grid = RoomGrid();
  const Eigen::Vector2i cell = *grid.CellAtGridPoint(2.02, 0.01);
  BandCoverage two_views(grid, 0.01);
  two_views.AddView(RenderView(camera, false, 0, 200), rays, camera.width, 4.0, 1);
  two_views.AddView(RenderView(camera, false, 280), rays, camera.width, 4.0, 1);
  EXPECT_EQ(two_views.UnseenLayer(cell.x(), cell.y()), 0.0);
  const KeyframeView upper = RenderView(camera, false, 0, 200);
  const KeyframeView lower = RenderView(camera, false, 280);
  KeyframeView both = upper;
  both.depth = cv::max(upper.depth, lower.depth);  // the same depth unit: the same wall at 3 m
  ASSERT_EQ(upper.depth_unit_m, lower.depth_unit_m);
  BandCoverage one_view(grid, 0.01);
  one_view.AddView(both, rays, camera.width, 4.0, 1);
  // Rows 200-280 span 80 / 525 rad: at 2 m, 30 cm of height.
  EXPECT_GE(one_view.UnseenLayer(cell.x(), cell.y()), 0.25);
}

TEST(BandCoverageViewsTest, ALayerMissedWhereAViewLooksSteeplyIsNoTopSeenEdgeOn) {
  // The bare room from 1.6 m, pitched 40 degrees down, its rows 200-280 returning nothing (a dark
  // patch of floor): over x = 1 m their rays pass at 0.62-0.88 m, 35-44 degrees below the
  // camera. A flat top there would have returned a reading, so the hole is no top seen edge-on.
  const Camera camera = SynthCamera();
  const std::vector<Eigen::Vector2f> rays = PixelRays(camera);
  const OccupancyGrid grid = RoomGrid();
  const Eigen::Isometry3d steep = WorldFromCamera(1.6, 40.0);
  KeyframeView view = RenderView(camera, false, 0, std::numeric_limits<int>::max(), steep);
  const KeyframeView lower = RenderView(camera, false, 280, std::numeric_limits<int>::max(), steep);
  view.depth = cv::max(RenderView(camera, false, 0, 200, steep).depth, lower.depth);
  const Eigen::Vector2i cell = *grid.CellAtGridPoint(1.02, 0.01);
  BandCoverage every_layer(grid, 0.01, 90.0);
  every_layer.AddView(view, rays, camera.width, 4.0, 1);
  EXPECT_GE(every_layer.UnseenLayer(cell.x(), cell.y()), 0.20);
  BandCoverage grazing(grid, 0.01, 10.0);
  grazing.AddView(view, rays, camera.width, 4.0, 1);
  EXPECT_EQ(grazing.UnseenLayer(cell.x(), cell.y()), 0.0);
}

TEST_F(BandCoverageTest, ATopSeenEdgeOnIsWithinTheGrazingAngle) {
  // From 0.90 m the top (0.72-0.76 m) over 1.2-2.0 m lies 4-7 degrees below the camera.
  const Camera camera = SynthCamera();
  BandCoverage grazing(grid_, 0.01, 10.0);
  grazing.AddView(RenderView(camera), PixelRays(camera), camera.width, 4.0, 1);
  const Eigen::Vector2i middle = *grid_.CellAtGridPoint(1.62, 0.01);
  EXPECT_EQ(grazing.UnseenLayer(middle.x(), middle.y()), UnseenAt(1.62, 0.01));
  EXPECT_GE(grazing.UnseenLayer(middle.x(), middle.y()), kTopTop - kTopBottom);
}

TEST(GridOptionsTest, UnseenLayerOptionsAreChecked) {
  GridOptions options;
  options.min_unseen_layer_m = -0.01;
  EXPECT_THROW(options.Validate(), InputError);
  options.min_unseen_layer_m = 0.0;  // off
  EXPECT_NO_THROW(options.Validate());
  options.unseen_layer_grazing_deg = 0.0;
  EXPECT_THROW(options.Validate(), InputError);
  options.unseen_layer_grazing_deg = 90.0;
  EXPECT_NO_THROW(options.Validate());
  options.unseen_layer_block_step = 0;
  EXPECT_THROW(options.Validate(), InputError);
}

}  // namespace
}  // namespace stillmap
