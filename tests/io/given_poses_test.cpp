#include "stillmap/io/given_poses.h"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "stillmap/io/error.h"
#include "test_util.h"

namespace stillmap {
namespace {

Eigen::Isometry3d Pose(double x, double yaw_rad) {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = Eigen::AngleAxisd(yaw_rad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  pose.translation() = Eigen::Vector3d(x, 0.1 * x, 0.3);
  return pose;
}

// A robot body's TUM trajectory (world_from_body) at 10 Hz, 0..1 s, with a gap 0.6..0.9 s.
std::string WriteBodyTrajectory(const testing::TempDir& dir) {
  std::string text = "# timestamp tx ty tz qx qy qz qw\n";
  for (int k = 0; k <= 10; ++k) {
    if (k == 7 || k == 8) continue;
    const double t = 100.0 + 0.1 * k;
    const Eigen::Isometry3d pose = Pose(0.1 * k, 0.2 * k);
    const Eigen::Quaterniond q(pose.linear());
    text += fmt::format("{:.6f} {:.12f} {:.12f} {:.12f} {:.15f} {:.15f} {:.15f} {:.15f}\n", t,
                        pose.translation().x(), pose.translation().y(), pose.translation().z(),
                        q.x(), q.y(), q.z(), q.w());
  }
  testing::WriteText(dir / "body.txt", text);
  return dir / "body.txt";
}

TEST(GivenPosesTest, ATrajectoryFileGivesTheBodysPoseTimesTheCameraInTheBody) {
  testing::TempDir dir;
  GivenPoseOptions options;
  // The camera 5 cm forward and 20 cm up on the body, looking along its x (optical z = body x).
  options.body_from_camera = {0, 0, 1, 0.05, -1, 0, 0, 0, 0, -1, 0, 0.2, 0, 0, 0, 1};
  options.max_gap_s = 0.15;
  ASSERT_NO_THROW(options.Validate());
  const std::optional<GivenPoseSource> source =
      ParseGivenPoseSource(WriteBodyTrajectory(dir), "run.poses");
  ASSERT_TRUE(source);
  const GivenPoses poses = GivenPoses::Open(Sequence{}, *source, options);
  Eigen::Isometry3d body_from_camera = Eigen::Isometry3d::Identity();
  body_from_camera.linear() << 0, 0, 1, -1, 0, 0, 0, -1, 0;
  body_from_camera.translation() << 0.05, 0, 0.2;
  // Halfway between two samples: the body half way along x, half way round in yaw (by hand).
  const std::optional<Eigen::Isometry3d> at = poses.At(100.25, nullptr);
  ASSERT_TRUE(at);
  const Eigen::Isometry3d expected = Pose(0.25, 0.5) * body_from_camera;
  EXPECT_TRUE(at->isApprox(expected, 1e-9)) << at->matrix() << "\n" << expected.matrix();
  LookupMiss miss;
  EXPECT_FALSE(poses.At(100.75, &miss));  // in the 0.3 s gap
  EXPECT_EQ(miss.kind, LookupMiss::Kind::kGap);
  EXPECT_FALSE(poses.At(99.5, &miss));
  EXPECT_EQ(miss.kind, LookupMiss::Kind::kBefore);
  EXPECT_NEAR(miss.seconds, 0.5, 1e-9);
  EXPECT_NE(poses.description().find("placed in its body by body_from_camera"), std::string::npos)
      << poses.description();
}

TEST(GivenPosesTest, SaysWhatIsWrongWithTheSourceNamed) {
  EXPECT_FALSE(ParseGivenPoseSource("tracking", "run.poses"));
  EXPECT_FALSE(ParseGivenPoseSource("groundtruth", "run.poses"));
  EXPECT_EQ(ParseGivenPoseSource("tf:map", "run.poses")->kind, GivenPoseSource::Kind::kTf);
  EXPECT_EQ(ParseGivenPoseSource("odom:/odom", "run.poses")->value, "/odom");
  EXPECT_NE(testing::ErrorOf([] {
              ParseGivenPoseSource("tf:", "run.poses");
            }).find("run.poses=tf:: name the frame after 'tf:' (tf:odom)"),
            std::string::npos);
  // tf: and odom: read a bag; a folder is told to give a file.
  const std::string folder = testing::ErrorOf(
      [] { GivenPoses::Open(Sequence{}, *ParseGivenPoseSource("tf:odom", "run.poses"), {}); });
  EXPECT_NE(folder.find("is a folder, not a recorded bag"), std::string::npos) << folder;
  EXPECT_NE(folder.find("--poses FILE"), std::string::npos) << folder;
  GivenPoseOptions options;
  options.use = "both";
  EXPECT_NE(testing::ErrorOf([&] { options.Validate(); }).find("use must be map or prior"),
            std::string::npos);
  options.use = "prior";
  options.body_from_camera[0] = 2.0;  // not a rotation
  EXPECT_NE(testing::ErrorOf([&] {
              options.Validate();
            }).find("body_from_camera must be a rigid transform"),
            std::string::npos);
  const std::string missing = testing::ErrorOf([] {
    GivenPoses::Open(Sequence{}, *ParseGivenPoseSource("/nonexistent/poses.txt", "run.poses"), {});
  });
  EXPECT_NE(missing.find("/nonexistent/poses.txt"), std::string::npos) << missing;
}

}  // namespace
}  // namespace stillmap
