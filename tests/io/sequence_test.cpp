#include "stillmap/io/sequence.h"

#include <gtest/gtest.h>

#include <filesystem>

#include "stillmap/io/error.h"
#include "test_util.h"

namespace stillmap {
namespace {

using testing::TempDir;
using testing::WriteText;

std::vector<Eigen::Isometry3d> SlideAlongX(int n) {
  std::vector<Eigen::Isometry3d> poses;
  for (int i = 0; i < n; ++i) {
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.translation().x() = 0.01 * i;
    poses.push_back(pose);
  }
  return poses;
}

TEST(SequenceTest, OpensAndDecodesAPlaneSequence) {
  TempDir dir;
  const Camera camera = testing::SmallCamera();
  testing::WritePlaneSequence(dir.path(), camera, {}, SlideAlongX(3));
  const Camera resolved = ResolveCamera(dir.path(), {});
  EXPECT_DOUBLE_EQ(resolved.fx, camera.fx);
  const Sequence sequence = Sequence::Open(dir.path(), resolved);
  ASSERT_EQ(sequence.frames().size(), 3u);
  ASSERT_TRUE(sequence.groundtruth().has_value());
  const Frame frame = sequence.LoadFrame(1);
  EXPECT_EQ(frame.color.type(), CV_8UC3);
  // The plane z = 2 m seen head-on: every pixel reads 2 m.
  EXPECT_FLOAT_EQ(frame.depth_m.at<float>(10, 10), 2.0f);
}

TEST(SequenceTest, CameraComesFromPresetOrKeysWhenNoYaml) {
  TempDir dir;
  testing::WritePlaneSequence(dir.path(), testing::SmallCamera(), {}, SlideAlongX(2));
  std::filesystem::remove(dir / "camera.yaml");
  EXPECT_THROW(ResolveCamera(dir.path(), {}), InputError);
  CameraOverrides overrides;
  overrides.preset = "ros_default";
  overrides.depth_factor = 1000.0;
  const Camera camera = ResolveCamera(dir.path(), overrides);
  EXPECT_DOUBLE_EQ(camera.fx, 525.0);
  EXPECT_DOUBLE_EQ(camera.depth_factor, 1000.0);
  CameraOverrides keys;
  keys.fx = keys.fy = 50.0;
  keys.cx = keys.cy = 20.0;
  EXPECT_DOUBLE_EQ(ResolveCamera(dir.path(), keys).cx, 20.0);
}

TEST(SequenceTest, BadLayoutsAreInputErrors) {
  TempDir dir;
  const Camera camera = testing::SmallCamera();
  EXPECT_THROW(Sequence::Open(dir / "nowhere", camera), InputError);
  testing::WritePlaneSequence(dir.path(), camera, {}, SlideAlongX(2));
  // Depth 0.5 s later than color: no pair within 0.02 s.
  WriteText(dir / "depth.txt", "1000.5 depth/1000.000000.png\n1000.6 depth/1000.033333.png\n");
  EXPECT_THROW(Sequence::Open(dir.path(), camera), InputError);
  std::filesystem::remove(dir / "depth.txt");
  EXPECT_THROW(Sequence::Open(dir.path(), camera), InputError);
}

TEST(SequenceTest, ImageSizeMustMatchTheCamera) {
  TempDir dir;
  testing::WritePlaneSequence(dir.path(), testing::SmallCamera(), {}, SlideAlongX(1));
  const Sequence sequence = Sequence::Open(dir.path(), testing::SmallCamera(80, 60));
  EXPECT_THROW(sequence.LoadFrame(0), InputError);
}

TEST(SequenceTest, GroundTruthOfABodyIsConvertedToTheCamera) {
  TempDir dir;
  testing::WritePlaneSequence(dir.path(), testing::SmallCamera(), {}, SlideAlongX(2));
  WriteText(
      dir / "camera.yaml",
      testing::ReadText(dir / "camera.yaml") +
          "groundtruth_body_from_camera: [0, 0, 1, 0.5, -1, 0, 0, 0, 0, -1, 0, 0, 0, 0, 0, 1]\n");
  const Camera camera = ResolveCamera(dir.path(), {});
  const Sequence sequence = Sequence::Open(dir.path(), camera);
  const Eigen::Isometry3d world_from_camera = sequence.groundtruth()->poses()[1].world_from_camera;
  // world_from_body = translation (0.01, 0, 0); camera = body * body_from_camera.
  EXPECT_NEAR(world_from_camera.translation().x(), 0.51, 1e-9);
  EXPECT_NEAR(world_from_camera.linear()(0, 2), 1.0, 1e-9);  // camera z along world x
}

}  // namespace
}  // namespace stillmap
