#include "stillmap/tracking/pose_estimation.h"

#include <gtest/gtest.h>

#include <random>

#include "stillmap/tracking/pose_refinement.h"

namespace stillmap {
namespace {

Eigen::Isometry3d TruePose() {
  Eigen::Isometry3d camera_from_world = Eigen::Isometry3d::Identity();
  camera_from_world.linear() =
      Eigen::AngleAxisd(0.3, Eigen::Vector3d(0.1, 1.0, 0.2).normalized()).toRotationMatrix();
  camera_from_world.translation() = Eigen::Vector3d(0.2, -0.1, 0.5);
  return camera_from_world;
}

// Translation [m] and rotation angle [rad] of `estimate` within `tolerance` of `truth`.
void ExpectSamePose(const Eigen::Isometry3d& estimate, const Eigen::Isometry3d& truth,
                    double tolerance) {
  EXPECT_LT((estimate.translation() - truth.translation()).norm(), tolerance);
  EXPECT_LT(Eigen::AngleAxisd(estimate.linear().transpose() * truth.linear()).angle(), tolerance);
}

TEST(PoseEstimationTest, PnpWithInjectedOutliersReturnsTheTruePose) {
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> lateral(-1.5, 1.5), depth(1.0, 4.0), pixel(-0.6, 0.6);
  const Eigen::Isometry3d camera_from_world = TruePose();
  std::vector<Eigen::Vector3d> points;
  std::vector<Eigen::Vector2d> observations;
  std::vector<bool> outlier;
  for (int i = 0; i < 300; ++i) {
    const Eigen::Vector3d in_camera(lateral(rng), lateral(rng), depth(rng));
    points.push_back(camera_from_world.inverse() * in_camera);
    const bool wrong = i % 10 < 3;  // 30 % outliers: random observations
    observations.push_back(
        wrong ? Eigen::Vector2d(pixel(rng), pixel(rng))
              : Eigen::Vector2d(in_camera.x() / in_camera.z(), in_camera.y() / in_camera.z()));
    outlier.push_back(wrong);
  }
  const PoseResult result = EstimatePosePnp(points, observations);
  ASSERT_TRUE(result.ok());
  ExpectSamePose(result.camera_from_world, camera_from_world, 1e-6);
  EXPECT_LT(result.reprojection_rmse, 1e-6);
  int wrong_inliers = 0;
  for (int i : result.inliers) wrong_inliers += outlier[static_cast<size_t>(i)];
  EXPECT_EQ(result.inliers.size(), 210u);
  EXPECT_EQ(wrong_inliers, 0);
}

TEST(PoseRefinementTest, ConvergesFromAPerturbedPoseAndFlagsOutliers) {
  std::mt19937 rng(8);
  std::uniform_real_distribution<double> lateral(-1.5, 1.5), depth(1.0, 4.0), wrong(-0.5, 0.5);
  const Eigen::Isometry3d camera_from_world = TruePose();
  std::vector<Eigen::Vector3d> points;
  std::vector<RgbdObservation> observations;
  for (int i = 0; i < 200; ++i) {
    const Eigen::Vector3d in_camera(lateral(rng), lateral(rng), depth(rng));
    points.push_back(camera_from_world.inverse() * in_camera);
    RgbdObservation observation;
    observation.normalized = in_camera.head<2>() / in_camera.z();
    observation.depth_m = i % 4 == 0 ? 0.0 : in_camera.z();  // a quarter without depth
    if (i % 10 == 9) observation.normalized += Eigen::Vector2d(wrong(rng), wrong(rng));  // outlier
    observations.push_back(observation);
  }
  Eigen::Isometry3d start = camera_from_world;
  start.translation() += Eigen::Vector3d(0.02, -0.01, 0.015);
  start.linear() =
      Eigen::AngleAxisd(0.03, Eigen::Vector3d(1, 0, 0)).toRotationMatrix() * start.linear();
  const PoseResult result = RefinePose(start, points, observations);
  ASSERT_TRUE(result.ok());
  ExpectSamePose(result.camera_from_world, camera_from_world, 1e-6);
  EXPECT_EQ(result.inliers.size(), 180u);
  for (int i : result.inliers) EXPECT_NE(i % 10, 9);
}

TEST(PoseEstimationTest, TooFewPointsIsAStatusNotAPose) {
  const PoseResult result = EstimatePosePnp({{0, 0, 1}, {1, 0, 1}}, {{0, 0}, {1, 0}});
  EXPECT_FALSE(result.ok());
  EXPECT_EQ(result.status, PoseStatus::kTooFewPoints);
}

}  // namespace
}  // namespace stillmap
