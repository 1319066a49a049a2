#include "stillmap/mapping/mapper.h"

#include <gtest/gtest.h>

#include "stillmap/io/cloud_files.h"
#include "stillmap/io/sequence.h"
#include "test_util.h"

namespace stillmap {
namespace {

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

}  // namespace
}  // namespace stillmap
