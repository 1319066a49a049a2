#include "stillmap/mapping/mapper.h"

#include <gtest/gtest.h>

#include "stillmap/io/cloud_files.h"
#include "stillmap/io/sequence.h"
#include "test_util.h"

namespace stillmap {
namespace {

// A frame of a flat surface depth_m straight ahead, the camera at x along the world's x axis.
MapperFrame FlatFrame(const Camera& camera, float depth_m, double x) {
  MapperFrame input;
  input.color = cv::Mat(camera.height, camera.width, CV_8UC3, cv::Scalar(90, 120, 150));
  input.depth_m = cv::Mat(camera.height, camera.width, CV_32FC1, cv::Scalar(depth_m));
  input.world_from_camera.translation() = Eigen::Vector3d(x, 0.0, 0.0);
  return input;
}

MapperOptions OnTheCallingThread() {
  MapperOptions options;
  options.in_background = false;
  return options;
}

// A camera circling in front of a tilted plane; every fused point must lie on the plane, which
// holds only if back-projection, the pose chain and the voxel averaging are all right.
TEST(MapperTest, FusedCloudOfATiltedPlaneLiesOnThePlane) {
  testing::TempDir dir;
  const Camera camera = testing::SmallCamera(96, 72);
  testing::PlaneScene scene;
  scene.normal = Eigen::Vector3d(0.3, -0.2, -1.0).normalized();
  scene.distance = -2.5;
  std::vector<Eigen::Isometry3d> poses;
  for (int i = 0; i < 8; ++i) {
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.linear() =
        Eigen::AngleAxisd(0.05 * i, Eigen::Vector3d(0, 1, 0.3).normalized()).toRotationMatrix();
    pose.translation() = Eigen::Vector3d(0.1 * std::cos(i), 0.1 * std::sin(i), 0.02 * i);
    poses.push_back(pose);
  }
  testing::WritePlaneSequence(dir.path(), camera, scene, poses);
  const Sequence sequence = Sequence::Open(dir.path(), camera);
  MapperOptions options;
  options.back_projection.smoothing_radius = 0;  // this test is about poses; see SmoothDepth's
  Mapper mapper(camera, options);
  for (size_t i = 0; i < sequence.frames().size(); ++i) {
    const Frame frame = sequence.LoadFrame(i);
    MapperFrame input;
    input.color = frame.color;
    input.depth_m = frame.depth_m;
    input.world_from_camera = *sequence.groundtruth()->Interpolate(frame.time, 0.1);
    mapper.Integrate(input);
  }
  const FinishedMap map = mapper.Finish();
  EXPECT_THROW(mapper.Finish(), std::logic_error);  // the map has one owner
  EXPECT_EQ(map.statistics.frames, 8u);
  const std::vector<VoxelPoint> points = map.cloud.Points();
  ASSERT_GT(points.size(), 1000u);
  double worst = 0.0;
  for (const VoxelPoint& p : points) {
    worst = std::max(worst, std::abs(scene.normal.dot(p.position.cast<double>()) - scene.distance));
  }
  // Depth is quantized to 0.2 mm; the voxel centroid of points on a plane stays on it.
  EXPECT_LT(worst, 1e-3);

  map.WriteCloud(dir / "map.ply", dir / "map.pcd");
  const std::vector<VoxelPoint> ply = ReadCloud(dir / "map.ply");
  const std::vector<VoxelPoint> pcd = ReadCloud(dir / "map.pcd");
  ASSERT_EQ(ply.size(), points.size());
  ASSERT_EQ(pcd.size(), points.size());
  EXPECT_EQ(ply[10].position, points[10].position);
  EXPECT_EQ(pcd[10].rgb, points[10].rgb);
}

// A loop correction moves keyframes fused earlier: Reset empties the map, and the frames fused
// again at their corrected poses give exactly the map of a mapper that only ever saw those poses,
// with no trace of the first fusion (the plane where the drifted poses put it).
TEST(MapperTest, ResetAndRefusingGiveTheMapOfTheCorrectedPosesOnly) {
  testing::TempDir dir;
  const Camera camera = testing::SmallCamera(96, 72);
  testing::PlaneScene scene;
  scene.normal = Eigen::Vector3d(0.0, 0.0, -1.0);
  scene.distance = -2.0;
  std::vector<Eigen::Isometry3d> poses;
  for (int i = 0; i < 4; ++i) {
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.translation() = Eigen::Vector3d(0.05 * i, 0.0, 0.0);
    poses.push_back(pose);
  }
  testing::WritePlaneSequence(dir.path(), camera, scene, poses);
  const Sequence sequence = Sequence::Open(dir.path(), camera);
  auto frame_at = [&](size_t i, const Eigen::Isometry3d& world_from_camera) {
    const Frame frame = sequence.LoadFrame(i);
    return MapperFrame{frame.time,        frame.color, frame.depth_m, cv::Mat(),
                       world_from_camera, false,       cv::Mat()};
  };
  Eigen::Isometry3d drift = Eigen::Isometry3d::Identity();
  drift.translation() = Eigen::Vector3d(0.0, 0.0, 0.2);  // the plane 20 cm off
  Mapper corrected(camera, MapperOptions{});
  Mapper fresh(camera, MapperOptions{});
  for (size_t i = 0; i < poses.size(); ++i) corrected.Integrate(frame_at(i, drift * poses[i]));
  corrected.Reset();
  for (size_t i = 0; i < poses.size(); ++i) {
    corrected.Integrate(frame_at(i, poses[i]));
    fresh.Integrate(frame_at(i, poses[i]));
  }
  const FinishedMap a = corrected.Finish();
  const FinishedMap b = fresh.Finish();
  EXPECT_EQ(a.statistics.refusions, 1u);
  EXPECT_EQ(a.statistics.frames, poses.size());
  const std::vector<VoxelPoint> pa = a.cloud.Points(), pb = b.cloud.Points();
  ASSERT_EQ(pa.size(), pb.size());
  ASSERT_GT(pa.size(), 100u);
  for (size_t i = 0; i < pa.size(); ++i) {
    EXPECT_EQ(pa[i].position, pb[i].position);
    EXPECT_LT(std::abs(pa[i].position.z() - 2.0f), 1e-3f);  // on the plane, none 20 cm off
  }
  ASSERT_TRUE(a.occupancy && b.occupancy);
  EXPECT_EQ(a.occupancy->LeafCount(), b.occupancy->LeafCount());
}

// Two recordings of a room where a screen 2 m ahead was taken away between them (the later one
// sees the wall 3 m ahead): merged as sessions, the later wins, in the OctoMap's free space and in
// the cleaned cloud; fused as one recording, the earlier and more numerous views keep the screen
// in the OctoMap.
TEST(MapperTest, ALaterSessionReplacesWhatMovedAway) {
  const Camera camera = testing::SmallCamera(96, 72);
  auto merged = [&](bool sessions) {
    const MapperOptions options = OnTheCallingThread();
    Mapper mapper(camera, options);
    for (int k = 0; k < 8; ++k) mapper.Integrate(FlatFrame(camera, 2.02f, 0.01 * (k % 6)));
    if (sessions) mapper.BeginLaterSession(camera);
    for (int k = 0; k < 6; ++k) mapper.Integrate(FlatFrame(camera, 3.02f, 0.01 * k));
    FinishedMap map = mapper.Finish();
    map.CleanCloud(options.cleaning);
    return map;
  };
  const FinishedMap later_wins = merged(true);
  ASSERT_TRUE(later_wins.occupancy);
  // The screen's voxel is 2.00-2.05 m ahead, the wall's 3.00-3.05 m.
  EXPECT_LT(later_wins.occupancy->Occupancy({0.0, 0.0, 2.025}), 0.5);
  EXPECT_GE(later_wins.occupancy->Occupancy({0.0, 0.0, 2.025}), 0.0);
  EXPECT_GT(later_wins.occupancy->Occupancy({0.0, 0.0, 3.025}), 0.5);
  size_t screen = 0, wall = 0;
  for (const VoxelPoint& point : later_wins.cloud.Points()) {
    (point.position.z() < 2.5f ? screen : wall) += 1;
  }
  EXPECT_EQ(screen, 0u);
  EXPECT_GT(wall, 1000u);
  EXPECT_EQ(later_wins.views.back().session, 1);

  const FinishedMap one_recording = merged(false);
  EXPECT_GT(one_recording.occupancy->Occupancy({0.0, 0.0, 2.025}), 0.5);
}

// A person 2 m ahead in one frame, then two frames of the wall 3 m behind them with the left half
// masked (someone else stood there), then six rays-only frames of the whole wall (keyframes that
// add nothing new): their rays alone clear the person's left half from the OctoMap and so from the
// cleaned cloud, and add no points and no views. Without them the left half stays.
TEST(MapperTest, RaysOnlyFramesClearWhatTheySeeThroughButAddNoPoints) {
  const Camera camera = testing::SmallCamera(96, 72);
  auto fused = [&](int rays_only_frames) {
    const MapperOptions options = OnTheCallingThread();
    Mapper mapper(camera, options);
    mapper.Integrate(FlatFrame(camera, 2.02f, 0.0));
    for (int k = 0; k < 2; ++k) {
      MapperFrame wall = FlatFrame(camera, 3.02f, 0.01 * k);
      wall.mask = cv::Mat(camera.height, camera.width, CV_8UC1, cv::Scalar(0));
      wall.mask.colRange(0, camera.width / 2).setTo(255);
      mapper.Integrate(wall);
    }
    for (int k = 0; k < rays_only_frames; ++k) {
      MapperFrame wall = FlatFrame(camera, 3.02f, 0.01 * k);
      wall.rays_only = true;
      mapper.Integrate(wall);
    }
    FinishedMap map = mapper.Finish();
    map.CleanCloud(options.cleaning);
    return map;
  };
  // Points left (x < -5 cm) or right (x > 5 cm) of the axis, at the person's or the wall's depth.
  auto count = [](const FinishedMap& map, bool wall, bool left) {
    size_t n = 0;
    for (const VoxelPoint& point : map.cloud.Points()) {
      const float x = point.position.x();
      if ((point.position.z() > 2.5f) == wall && (left ? x < -0.05f : x > 0.05f)) ++n;
    }
    return n;
  };
  const FinishedMap rays = fused(6);
  ASSERT_TRUE(rays.occupancy);
  EXPECT_LT(rays.occupancy->Occupancy({-0.3, 0.0, 2.025}), 0.5);
  EXPECT_GT(rays.occupancy->Occupancy({-0.3, 0.0, 3.025}), 0.5);
  EXPECT_EQ(count(rays, false, true), 0u);
  EXPECT_EQ(count(rays, true, true), 0u);  // no points of their own
  EXPECT_GT(count(rays, true, false), 100u);
  EXPECT_EQ(rays.statistics.frames, 3u);
  EXPECT_EQ(rays.statistics.rays_only_frames, 6u);
  EXPECT_EQ(rays.views.size(), 3u);

  const FinishedMap without = fused(0);
  EXPECT_GT(without.occupancy->Occupancy({-0.3, 0.0, 2.025}), 0.5);
  EXPECT_GT(count(without, false, true), 100u);
  EXPECT_EQ(count(without, true, false), count(rays, true, false));
}

// The grid's views (Mapper's keep_grid_views) take every static reading of a frame: the
// cells the fuser leaves out because earlier keyframes fused them (in `mask`, not in
// `moving_mask`) are rays the grid needs, the moving pixels are not.
TEST(MapperTest, GridViewsKeepTheCellsFusedBeforeAndLeaveTheMovingOnesOut) {
  const Camera camera = testing::SmallCamera(96, 72);
  cv::Mat depth_m(camera.height, camera.width, CV_32FC1, cv::Scalar(2.0f));
  cv::Mat moving(depth_m.size(), CV_8UC1, cv::Scalar(0));
  moving(cv::Rect(0, 0, 24, 72)).setTo(255);  // a person on the left
  cv::Mat mask = moving.clone();
  mask(cv::Rect(48, 0, 48, 72)).setTo(255);  // the right half fused before
  Mapper mapper(camera, OnTheCallingThread(), true);
  MapperFrame frame{0.0,
                    cv::Mat(depth_m.size(), CV_8UC3, cv::Scalar(90, 90, 90)),
                    depth_m,
                    mask,
                    Eigen::Isometry3d::Identity(),
                    false,
                    moving};
  mapper.Integrate(frame);
  const FinishedMap map = mapper.Finish();
  ASSERT_EQ(map.views.size(), 1u);
  ASSERT_EQ(map.grid_views.size(), 1u);
  const KeyframeView& view = map.views.front();
  const KeyframeView& grid = map.grid_views.front();
  EXPECT_EQ(grid.depth.cols * grid.block, camera.width);
  EXPECT_EQ(grid.block, 4);
  EXPECT_EQ(view.Reading(10, 40), 0.0f);          // fused before: not the cleaning's
  EXPECT_NEAR(grid.Reading(5, 20), 2.0f, 1e-3f);  // but the grid's
  EXPECT_EQ(grid.Reading(5, 2), 0.0f);            // the person is no one's
  EXPECT_EQ(view.Reading(10, 4), 0.0f);
  EXPECT_NEAR(grid.Reading(5, 8), 2.0f, 1e-3f);  // static, between the two
}

}  // namespace
}  // namespace stillmap
