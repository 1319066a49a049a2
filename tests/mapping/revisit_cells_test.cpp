// RevisitCells against exact geometry: a wall 2 m in front of the first keyframe, rendered by
// ray casting for every later view.
#include "stillmap/mapping/revisit_cells.h"

#include <gtest/gtest.h>

#include "stillmap/io/error.h"

namespace stillmap {
namespace {

Camera TestCamera() {
  Camera camera;
  camera.fx = camera.fy = 525.0;
  camera.cx = 319.5;
  camera.cy = 239.5;
  return camera;
}

// Depth [m] of the plane z = wall_z (world) seen from `world_from_camera`; pixels with
// u < box_columns read `box_depth_m` instead (something new in front of the wall).
cv::Mat RenderWall(const Camera& camera, const Eigen::Isometry3d& world_from_camera,
                   double wall_z = 2.0, int box_columns = 0, float box_depth_m = 0.0f) {
  cv::Mat depth(camera.height, camera.width, CV_32FC1, cv::Scalar(0));
  for (int v = 0; v < camera.height; ++v) {
    for (int u = 0; u < camera.width; ++u) {
      const Eigen::Vector3d ray((u - camera.cx) / camera.fx, (v - camera.cy) / camera.fy, 1.0);
      const Eigen::Vector3d direction = world_from_camera.linear() * ray;
      const double along = (wall_z - world_from_camera.translation().z()) / direction.z();
      if (along > 0.0) depth.at<float>(v, u) = static_cast<float>(along);  // ray.z() == 1
      if (u < box_columns) depth.at<float>(v, u) = box_depth_m;
    }
  }
  return depth;
}

Eigen::Isometry3d At(double x, double z = 0.0, double yaw_deg = 0.0) {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = Eigen::AngleAxisd(yaw_deg * M_PI / 180.0, Eigen::Vector3d::UnitY()).matrix();
  pose.translation() = Eigen::Vector3d(x, 0.0, z);
  return pose;
}

// Keyframe 0 at the origin, remembered; returns the cells seen before of keyframe `id` at `pose`.
cv::Mat SeenAfterFirst(RevisitCells* cells, const Camera& camera, int id,
                       const Eigen::Isometry3d& pose, const cv::Mat& depth) {
  cells->Remember(cells->MakeView(0, RenderWall(camera, At(0.0)), cv::Mat(), At(0.0)));
  return cells->SeenBefore(cells->MakeView(id, depth, cv::Mat(), pose));
}

TEST(RevisitCellsTest, ARevisitDriftedByACentimetreAddsNothing) {
  const Camera camera = TestCamera();
  RevisitCells cells(camera, RevisitOptions{}, 0.1, 4.0);
  const Eigen::Isometry3d drifted = At(0.01);
  const cv::Mat seen = SeenAfterFirst(&cells, camera, 10, drifted, RenderWall(camera, drifted));
  ASSERT_FALSE(seen.empty());
  // 1 cm at 2 m is 2.6 px: the last column of cells reaches past the first view's edge.
  EXPECT_EQ(cv::countNonZero(seen(cv::Rect(0, 0, camera.width - 16, camera.height))),
            (camera.width - 16) * camera.height);
  EXPECT_EQ(cv::countNonZero(seen(cv::Rect(camera.width - 16, 0, 16, camera.height))), 0);
  EXPECT_EQ(cells.cells_left_out(), 39u * 30u);
}

TEST(RevisitCellsTest, KeyframesOfTheSameVisitFuseAll) {
  const Camera camera = TestCamera();
  RevisitCells cells(camera, RevisitOptions{}, 0.1, 4.0);  // keyframes_apart 8
  EXPECT_TRUE(SeenAfterFirst(&cells, camera, 7, At(0.0), RenderWall(camera, At(0.0))).empty());
  EXPECT_EQ(cells.cells_left_out(), 0u);
}

TEST(RevisitCellsTest, WhatTheEarlierVisitSawAtAnotherDepthStays) {
  const Camera camera = TestCamera();
  RevisitCells cells(camera, RevisitOptions{}, 0.1, 4.0);
  // A box 0.8 m in front of the wall over the left 160 columns (10 cells).
  const cv::Mat seen =
      SeenAfterFirst(&cells, camera, 10, At(0.0), RenderWall(camera, At(0.0), 2.0, 160, 1.2f));
  ASSERT_FALSE(seen.empty());
  EXPECT_EQ(cv::countNonZero(seen(cv::Rect(0, 0, 160, camera.height))), 0);
  EXPECT_EQ(cv::countNonZero(seen(cv::Rect(160, 0, camera.width - 160, camera.height))),
            (camera.width - 160) * camera.height);
}

TEST(RevisitCellsTest, ACellTheEarlierViewSawOnlyInPartStays) {
  const Camera camera = TestCamera();
  RevisitCells cells(camera, RevisitOptions{}, 0.1, 4.0);
  // A person masked over 4 px of each cell of the first view's top row of cells.
  cv::Mat mask(camera.height, camera.width, CV_8UC1, cv::Scalar(0));
  for (int u = 0; u < camera.width; u += 16) mask(cv::Rect(u, 0, 4, 16)).setTo(255);
  cells.Remember(cells.MakeView(0, RenderWall(camera, At(0.0)), mask, At(0.0)));
  const cv::Mat seen =
      cells.SeenBefore(cells.MakeView(10, RenderWall(camera, At(0.0)), cv::Mat(), At(0.0)));
  ASSERT_FALSE(seen.empty());
  EXPECT_EQ(cv::countNonZero(seen(cv::Rect(0, 0, camera.width, 16))), 0);
  EXPECT_EQ(cv::countNonZero(seen(cv::Rect(0, 16, camera.width, camera.height - 16))),
            camera.width * (camera.height - 16));
}

TEST(RevisitCellsTest, TheSameWallFromAnotherDirectionOrDistanceStays) {
  const Camera camera = TestCamera();
  {
    RevisitCells cells(camera, RevisitOptions{}, 0.1, 4.0);
    // 1.2 m to the side, turned 31 degrees towards the first view's centre: 31 > 15 degrees.
    const Eigen::Isometry3d aside = At(1.2, 0.0, -31.0);
    EXPECT_TRUE(SeenAfterFirst(&cells, camera, 10, aside, RenderWall(camera, aside)).empty());
  }
  {
    RevisitCells cells(camera, RevisitOptions{}, 0.1, 4.0);
    // 1 m nearer: half the distance, beyond the scale ratio of 1.25.
    const Eigen::Isometry3d nearer = At(0.0, 1.0);
    EXPECT_TRUE(SeenAfterFirst(&cells, camera, 10, nearer, RenderWall(camera, nearer)).empty());
  }
}

TEST(RevisitCellsTest, ALoopCorrectionMovesTheRememberedViews) {
  const Camera camera = TestCamera();
  RevisitCells cells(camera, RevisitOptions{}, 0.1, 4.0);
  cells.Remember(cells.MakeView(0, RenderWall(camera, At(0.0)), cv::Mat(), At(0.0)));
  // Corrected: keyframe 0 was in fact 0.3 m to the right, so it saw the wall's right part only.
  cells.Repose({{0, At(0.3)}});
  const cv::Mat seen =
      cells.SeenBefore(cells.MakeView(10, RenderWall(camera, At(0.0)), cv::Mat(), At(0.0)));
  ASSERT_FALSE(seen.empty());
  // 0.3 m at 2 m is 79 px: the left 64 px (4 cells) were not in its view.
  EXPECT_EQ(cv::countNonZero(seen(cv::Rect(0, 0, 64, camera.height))), 0);
  EXPECT_EQ(cv::countNonZero(seen(cv::Rect(96, 0, camera.width - 96, camera.height))),
            (camera.width - 96) * camera.height);
}

TEST(RevisitCellsTest, SwitchedOffLeavesNothingOutAndBadValuesAreRefused) {
  const Camera camera = TestCamera();
  RevisitOptions off;
  off.enabled = false;
  RevisitCells cells(camera, off, 0.1, 4.0);
  EXPECT_TRUE(SeenAfterFirst(&cells, camera, 10, At(0.0), RenderWall(camera, At(0.0))).empty());
  RevisitOptions bad;
  bad.keyframes_apart = 0;
  EXPECT_THROW(bad.Validate(), InputError);
  bad = RevisitOptions{};
  bad.scale_ratio = 0.9;
  EXPECT_THROW(bad.Validate(), InputError);
  bad = RevisitOptions{};
  bad.max_seen_share = 1.5;
  EXPECT_THROW(bad.Validate(), InputError);
}

// Keyframe 0 at the origin; keyframe 10 0.1 m to its right (26 px at 2 m: its last two columns
// of cells are new, 38 of 40 seen); keyframe 20 0.4 m to the right, part of whose view only
// keyframe 10 saw. Returns keyframe 20's cells seen, after keyframe 10 was admitted or not.
cv::Mat SeenAfterARedundantRevisit(const Camera& camera, double max_seen_share,
                                   bool* second_admitted) {
  RevisitOptions options;
  options.max_seen_share = max_seen_share;
  RevisitCells cells(camera, options, 0.1, 4.0);
  EXPECT_TRUE(
      cells.Admit(cells.MakeView(0, RenderWall(camera, At(0.0)), cv::Mat(), At(0.0))).has_value());
  const std::optional<cv::Mat> second =
      cells.Admit(cells.MakeView(10, RenderWall(camera, At(0.1)), cv::Mat(), At(0.1)));
  *second_admitted = second.has_value();
  if (second) {
    EXPECT_NEAR(RevisitCells::SeenShare(
                    cells.MakeView(10, RenderWall(camera, At(0.1)), cv::Mat(), At(0.1)), *second),
                38.0 / 40.0, 1e-9);
  }
  return cells.SeenBefore(cells.MakeView(20, RenderWall(camera, At(0.4)), cv::Mat(), At(0.4)));
}

TEST(RevisitCellsTest, AKeyframeTheEarlierVisitSawIsRedundantAndNotRemembered) {
  const Camera camera = TestCamera();
  bool admitted = false;
  // 38 of 40 seen is more than 0.9: redundant, and what it alone saw counts for nobody after.
  const cv::Mat without = SeenAfterARedundantRevisit(camera, 0.9, &admitted);
  EXPECT_FALSE(admitted);
  // The same keyframe below the share, or with the rule off, is fused and remembered.
  const cv::Mat below = SeenAfterARedundantRevisit(camera, 0.96, &admitted);
  EXPECT_TRUE(admitted);
  const cv::Mat off = SeenAfterARedundantRevisit(camera, 1.0, &admitted);
  EXPECT_TRUE(admitted);
  // Keyframe 0 saw the wall up to x = 1.22 m, keyframe 10 up to 1.32 m: keyframe 20 sees that
  // last 0.1 m (26 px) at columns 535..560, where its cells 528..543 and 544..559 reach.
  ASSERT_FALSE(without.empty());
  const int columns_without = cv::countNonZero(without.row(240));
  EXPECT_GT(cv::countNonZero(below.row(240)), columns_without);
  EXPECT_EQ(cv::countNonZero(off.row(240)), cv::countNonZero(below.row(240)));
  // Without keyframe 10 it is keyframe 0's view only: no cell reaching past x = 1.22 m.
  EXPECT_EQ(cv::countNonZero(without(cv::Rect(528, 0, camera.width - 528, camera.height))), 0);
  EXPECT_EQ(cv::countNonZero(below(cv::Rect(528, 0, 32, camera.height))), 32 * camera.height);
}

// Across map segments the share counts whatever the keyframe ids: keyframe 1 of segment 1, 1 cm
// beside keyframe 0 of segment 0, saw 39 of its 40 columns of cells. Within segment 0 it is too
// near keyframe 0 to count as another visit.
TEST(RevisitCellsTest, AKeyframeAnotherSegmentSawIsRedundantWhateverItsId) {
  const Camera camera = TestCamera();
  for (const int segment : {1, 0}) {
    for (const double max_share : {0.9, 1.0}) {
      RevisitOptions options;
      options.segment_max_seen_share = max_share;
      RevisitCells cells(camera, options, 0.1, 4.0);
      ASSERT_TRUE(cells.AdmitAcrossSegments(
          cells.MakeView(0, RenderWall(camera, At(0.0)), cv::Mat(), At(0.0), 0)));
      const bool second = cells.AdmitAcrossSegments(
          cells.MakeView(1, RenderWall(camera, At(0.01)), cv::Mat(), At(0.01), segment));
      EXPECT_EQ(second, segment == 0 || max_share == 1.0)
          << "segment " << segment << ", share " << max_share;
    }
  }
}

// Within one segment, with segment_lap_path_m, a view counts as another segment's once the
// camera has travelled that far since it: keyframe 1 saw again what keyframe 0 saw, 12 m of path
// later (a lap) but not 8 m.
TEST(RevisitCellsTest, ItsOwnSegmentALapBackCountsAsAnotherSegment) {
  const Camera camera = TestCamera();
  for (const double path_m : {12.0, 8.0}) {
    RevisitOptions options;
    options.segment_max_seen_share = 0.9;
    options.segment_lap_path_m = 10.0;
    RevisitCells cells(camera, options, 0.1, 4.0);
    ASSERT_TRUE(cells.AdmitAcrossSegments(
        cells.MakeView(0, RenderWall(camera, At(0.0)), cv::Mat(), At(0.0), 0)));
    CellView view = cells.MakeView(1, RenderWall(camera, At(0.01)), cv::Mat(), At(0.01), 0);
    view.path_m = path_m;
    EXPECT_EQ(cells.AdmitAcrossSegments(std::move(view)), path_m < 10.0) << path_m << " m of path";
  }
}

// Views whose cameras lie too far for the distance ratio and angle are never asked (the bound
// RevisitCells uses to skip them): a view 0.45 m behind keyframe 0 (ranges 2.45 against 2 m,
// 1.225 x) still finds every cell seen, one 0.6 m behind (1.3 x) none.
TEST(RevisitCellsTest, EarlierViewsAtTheEdgeOfTheDistanceRatioAreStillAsked) {
  const Camera camera = TestCamera();
  for (const auto& [back, seen_cells] : {std::pair{0.45, true}, std::pair{0.6, false}}) {
    RevisitCells cells(camera, RevisitOptions{}, 0.1, 4.0);
    const Eigen::Isometry3d behind = At(0.0, -back);
    const cv::Mat seen = SeenAfterFirst(&cells, camera, 10, behind, RenderWall(camera, behind));
    const int middle = seen.empty() ? 0 : cv::countNonZero(seen(cv::Rect(240, 160, 160, 160)));
    EXPECT_EQ(middle, seen_cells ? 160 * 160 : 0) << back << " m behind";
  }
}

}  // namespace
}  // namespace stillmap
