#include "stillmap/io/trajectory.h"

#include <gtest/gtest.h>

#include <cmath>

#include "stillmap/io/error.h"
#include "test_util.h"

namespace stillmap {
namespace {

using testing::TempDir;
using testing::WriteText;

std::string ErrorOf(const std::string& path) {
  try {
    Trajectory::ReadTum(path);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

Eigen::Isometry3d Pose(double yaw, const Eigen::Vector3d& t) {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  pose.translation() = t;
  return pose;
}

TEST(TrajectoryTest, WriteThenReadIsIdentity) {
  TempDir dir;
  std::vector<StampedPose> poses;
  for (int i = 0; i < 10; ++i) {
    Eigen::Isometry3d pose = Pose(0.1 * i, Eigen::Vector3d(i, -0.5 * i, 0.25));
    pose.linear() = pose.linear() * Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 1, 0).normalized());
    poses.push_back({1341841873.273798 + i / 30.0, pose});
  }
  const Trajectory written(poses);
  written.WriteTum(dir / "t.txt");
  const Trajectory read = Trajectory::ReadTum(dir / "t.txt");
  ASSERT_EQ(read.size(), written.size());
  for (size_t i = 0; i < read.size(); ++i) {
    EXPECT_NEAR(read.poses()[i].time, written.poses()[i].time, 1e-6);
    EXPECT_TRUE(
        read.poses()[i].world_from_camera.isApprox(written.poses()[i].world_from_camera, 1e-8));
  }
}

TEST(TrajectoryTest, InterpolationIsSlerpAndLinear) {
  const Trajectory trajectory({{0.0, Pose(0.0, {0, 0, 0})}, {1.0, Pose(1.0, {2, 4, 0})}});
  const auto mid = trajectory.Interpolate(0.25, 2.0);
  ASSERT_TRUE(mid.has_value());
  EXPECT_TRUE(mid->isApprox(Pose(0.25, {0.5, 1.0, 0}), 1e-12));
  EXPECT_FALSE(trajectory.Interpolate(-0.01, 2.0).has_value());
  EXPECT_FALSE(trajectory.Interpolate(1.01, 2.0).has_value());
  EXPECT_FALSE(trajectory.Interpolate(0.5, 0.5).has_value());  // gap of 1 s > 0.5 s
  EXPECT_TRUE(trajectory.Interpolate(1.0, 0.5)->isApprox(Pose(1.0, {2, 4, 0})));
}

TEST(TrajectoryTest, MalformedLinesAreNamed) {
  TempDir dir;
  WriteText(dir / "nan.txt", "1 0 0 0 0 0 0 1\n2 0 nan 0 0 0 0 1\n");
  std::string error = ErrorOf(dir / "nan.txt");
  EXPECT_NE(error.find("nan.txt:2"), std::string::npos) << error;
  EXPECT_NE(error.find("not a finite number"), std::string::npos) << error;
  WriteText(dir / "norm.txt", "1 0 0 0 0 0 0 2\n");
  error = ErrorOf(dir / "norm.txt");
  EXPECT_NE(error.find("norm 2"), std::string::npos) << error;
  WriteText(dir / "short.txt", "1 0 0 0 0 0 1\n");
  EXPECT_NE(ErrorOf(dir / "short.txt").find("expected 8 numbers"), std::string::npos);
  WriteText(dir / "dup.txt", "1 0 0 0 0 0 0 1\n1 0 0 0 0 0 0 1\n");
  EXPECT_NE(ErrorOf(dir / "dup.txt").find("repeats"), std::string::npos);
  WriteText(dir / "unsorted.txt", "2 0 0 0 0 0 0 1\n1 0 0 0 0 0 0 1\n");
  EXPECT_NE(ErrorOf(dir / "unsorted.txt").find("earlier"), std::string::npos);
  WriteText(dir / "empty.txt", "# header only\n");
  EXPECT_NE(ErrorOf(dir / "empty.txt").find("no poses"), std::string::npos);
}

TEST(TrajectoryTest, SlightlyOffUnitQuaternionsAreNormalized) {
  TempDir dir;
  WriteText(dir / "t.txt", "1 0 0 0 -0.2651 0.7889 -0.5183 0.1970\n");  // TUM, 4 digits
  const Trajectory trajectory = Trajectory::ReadTum(dir / "t.txt");
  const Eigen::Matrix3d r = trajectory.poses()[0].world_from_camera.linear();
  EXPECT_NEAR((r.transpose() * r - Eigen::Matrix3d::Identity()).norm(), 0.0, 1e-12);
}

}  // namespace
}  // namespace stillmap
