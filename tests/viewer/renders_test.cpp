// The renders of a hand-made map: deterministic, the grid's cells where they belong, the cloud
// and the trajectory drawn.
#include "stillmap/viewer/renders.h"

#include <gtest/gtest.h>

namespace stillmap {
namespace {

RenderInput MakeInput() {
  RenderInput input;
  // A 2 m x 2 m floor patch (z up) with a red 0.4 m block on it, 2 cm apart.
  for (int i = 0; i < 100; ++i) {
    for (int j = 0; j < 100; ++j) {
      VoxelPoint p;
      p.position = Eigen::Vector3f(0.02f * i, 0.02f * j, 0.0f);
      p.rgb = {120, 120, 120};
      p.count = 3;
      input.cloud.push_back(p);
    }
  }
  for (int i = 0; i < 20; ++i) {
    for (int k = 0; k < 20; ++k) {
      VoxelPoint p;
      p.position = Eigen::Vector3f(0.8f + 0.02f * i, 1.0f, 0.02f * k);
      p.rgb = {255, 0, 0};
      p.count = 3;
      input.cloud.push_back(p);
    }
  }
  OccupancyGrid grid;
  grid.resolution = 0.1;
  grid.width = 20;
  grid.height = 20;
  grid.cells.assign(400, kGridFree);
  for (int i = 8; i < 12; ++i) grid.cells[static_cast<size_t>(10 * 20 + i)] = kGridOccupied;
  for (int i = 0; i < 20; ++i) grid.cells[static_cast<size_t>(19 * 20 + i)] = kGridUnknown;
  grid.floor.up = Eigen::Vector3d::UnitZ();
  grid.min_height = 0.1;
  grid.max_height = 1.5;
  input.grid = grid;
  for (int k = 0; k < 10; ++k) {
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.translation() = Eigen::Vector3d(0.2 + 0.1 * k, 0.3, 1.2);
    input.trajectory.push_back(pose);
    if (k % 3 == 0) input.keyframes.push_back(pose);
  }
  input.title = "test";
  return input;
}

TEST(RendersTest, DeterministicViewsShowTheGridAndTheCloud) {
  const RenderInput input = MakeInput();
  const auto views = RenderViews(input);
  ASSERT_EQ(views.size(), 3u);
  EXPECT_EQ(views[0].first, "grid_top.png");
  EXPECT_EQ(views[1].first, "cloud_view_1.png");
  EXPECT_EQ(views[2].first, "cloud_view_2.png");
  const auto again = RenderViews(input);
  for (size_t k = 0; k < views.size(); ++k) {
    EXPECT_EQ(cv::norm(views[k].second, again[k].second, cv::NORM_INF), 0.0) << views[k].first;
  }
  // Grid: 20 x 20 cells scaled into the drawing area (810 px high, with a twelfth kept for the
  // scale bar: 37.5 px a cell); the occupied row (j = 10, i = 8..11) is black, the unknown top
  // row gray, the rest white.
  const cv::Mat& top = views[0].second;
  auto count = [](const cv::Mat& image, const cv::Vec3b& color) {
    int n = 0;
    for (int v = 0; v < image.rows; ++v) {
      for (int u = 0; u < image.cols; ++u) n += image.at<cv::Vec3b>(v, u) == color ? 1 : 0;
    }
    return n;
  };
  const int black = count(top, cv::Vec3b(0, 0, 0));
  const int unknown = count(top, cv::Vec3b(205, 205, 205));
  const int white = count(top, cv::Vec3b(255, 255, 255));
  // 4 occupied cells, 20 unknown, 376 free (legend and text add a few pixels).
  const double cell = 37.5 * 37.5;
  EXPECT_GE(black, 4 * cell - 100);
  EXPECT_LE(black, 4 * cell + 1500);  // the scale bar is black too (3 px x about 300 px)
  EXPECT_NEAR(unknown, 20 * cell, 2 * cell);
  EXPECT_GT(white, 360 * cell);
  // Cloud views: red block pixels and the trajectory's blue are drawn.
  for (size_t k = 1; k < 3; ++k) {
    EXPECT_GT(count(views[k].second, cv::Vec3b(0, 0, 255)), 500) << views[k].first;
    EXPECT_GT(count(views[k].second, cv::Vec3b(120, 120, 120)), 20000) << views[k].first;
  }
}

int CountColor(const cv::Mat& image, const cv::Vec3b& color) {
  int n = 0;
  for (int v = 0; v < image.rows; ++v) {
    for (int u = 0; u < image.cols; ++u) n += image.at<cv::Vec3b>(v, u) == color ? 1 : 0;
  }
  return n;
}

// The trajectory is drawn over the keyframes: its full-colour pixels are the same with the
// keyframe markers as without them, in every view. The grid view shows the grid frame's axes
// (x red, y green, as long as the scale bar) from its origin.
TEST(RendersTest, TheTrajectoryLiesOverTheKeyframesAndTheGridShowsItsAxes) {
  RenderInput with = MakeInput();
  // Shift the grid frame so that its origin lies inside the drawn cells.
  with.grid->origin = Eigen::Vector2d(-1.0, -1.0);
  RenderInput without = with;
  without.keyframes.clear();
  const auto a = RenderViews(with);
  const auto b = RenderViews(without);
  const cv::Vec3b trajectory(200, 90, 20);
  for (size_t k = 0; k < a.size(); ++k) {
    EXPECT_GT(CountColor(b[k].second, trajectory), 100) << a[k].first;
    EXPECT_EQ(CountColor(a[k].second, trajectory), CountColor(b[k].second, trajectory))
        << a[k].first;
  }
  // The axes: 3 px wide and at least a fifth of the cells' width long (legend swatches add some).
  const cv::Mat& top = a[0].second;
  EXPECT_GT(CountColor(top, cv::Vec3b(0, 0, 220)), 3 * 100) << "x axis";
  EXPECT_GT(CountColor(top, cv::Vec3b(0, 160, 0)), 3 * 100) << "y axis";
}

}  // namespace
}  // namespace stillmap
