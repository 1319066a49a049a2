#include "stillmap/io/evaluation.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "test_util.h"

namespace stillmap {
namespace {

// A smooth hand-held-like trajectory: a loop with changing height and orientation.
std::vector<StampedPose> LoopTrajectory(size_t n, double rate_hz) {
  std::vector<StampedPose> poses;
  for (size_t i = 0; i < n; ++i) {
    const double t = static_cast<double>(i) / rate_hz;
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.translation() = Eigen::Vector3d(std::cos(0.5 * t), std::sin(0.5 * t), 0.2 * std::sin(t));
    pose.linear() = (Eigen::AngleAxisd(0.5 * t, Eigen::Vector3d::UnitZ()) *
                     Eigen::AngleAxisd(0.1 * std::sin(t), Eigen::Vector3d::UnitX()))
                        .toRotationMatrix();
    poses.push_back({100.0 + t, pose});
  }
  return poses;
}

Eigen::Isometry3d KnownTransform() {
  Eigen::Isometry3d transform = Eigen::Isometry3d::Identity();
  transform.linear() =
      Eigen::AngleAxisd(0.7, Eigen::Vector3d(0.2, -0.5, 1.0).normalized()).toRotationMatrix();
  transform.translation() = Eigen::Vector3d(3.0, -1.0, 0.5);
  return transform;
}

TEST(EvaluationTest, StatisticsMatchHandComputation) {
  const ErrorStatistics s = ComputeStatistics({1.0, 2.0, 3.0, 4.0});
  EXPECT_DOUBLE_EQ(s.mean, 2.5);
  EXPECT_DOUBLE_EQ(s.median, 2.5);
  EXPECT_DOUBLE_EQ(s.rmse, std::sqrt(30.0 / 4.0));
  EXPECT_DOUBLE_EQ(s.std_dev, std::sqrt(1.25));
  EXPECT_DOUBLE_EQ(s.min, 1.0);
  EXPECT_DOUBLE_EQ(s.max, 4.0);
}

TEST(EvaluationTest, RigidlyMovedTrajectoryHasZeroErrorAndTheAlignmentIsRecovered) {
  const Trajectory groundtruth(LoopTrajectory(300, 30.0));
  std::vector<StampedPose> moved = groundtruth.poses();
  for (StampedPose& pose : moved)
    pose.world_from_camera = KnownTransform() * pose.world_from_camera;
  const Trajectory estimate(moved);
  const AteResult ate = ComputeAte(groundtruth, estimate);
  EXPECT_EQ(ate.translation.count, 300u);
  EXPECT_LT(ate.translation.rmse, 1e-9);
  EXPECT_TRUE(ate.groundtruth_from_estimate.isApprox(KnownTransform().inverse(), 1e-9));
  const RpeResult rpe = ComputeRpe(groundtruth, estimate);
  EXPECT_LT(rpe.translation.rmse, 1e-9);
  EXPECT_LT(rpe.rotation.rmse, 1e-6);
}

TEST(EvaluationTest, FitPosesRecoversTheTransformOfAStraightPathFromItsOrientations) {
  // A straight path along x: its positions leave a rotation about x free, its orientations do
  // not. The estimate is the truth moved by a known transform, each rotation then turned by up to
  // 0.5 degrees about a random axis.
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  std::vector<Eigen::Isometry3d> truths, exact, noisy;
  for (int i = 0; i < 200; ++i) {
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.translation() = Eigen::Vector3d(0.02 * i, 0.0, 0.9);
    pose.linear() =
        Eigen::AngleAxisd(0.3 * std::sin(0.05 * i), Eigen::Vector3d::UnitZ()).toRotationMatrix();
    truths.push_back(pose);
    exact.push_back(KnownTransform() * pose);
    const Eigen::Vector3d axis = Eigen::Vector3d(unit(rng), unit(rng), unit(rng)).normalized();
    Eigen::Isometry3d turned = exact.back();
    turned.linear() = turned.linear() *
                      Eigen::AngleAxisd(0.5 * M_PI / 180.0 * unit(rng), axis).toRotationMatrix();
    noisy.push_back(turned);
  }
  EXPECT_TRUE(FitPoses(truths, exact).isApprox(KnownTransform().inverse(), 1e-9));
  const Eigen::Isometry3d fit = FitPoses(truths, noisy);
  const Eigen::AngleAxisd off(fit.linear() * KnownTransform().linear());
  EXPECT_LT(off.angle() * 180.0 / M_PI, 0.1);
  EXPECT_LT((fit * KnownTransform().translation()).norm(), 0.01);
}

TEST(EvaluationTest, KnownNoiseGivesExpectedAte) {
  // Isotropic Gaussian noise of sigma per axis: E[|e|^2] = 3 sigma^2, less the 6 degrees of
  // freedom the alignment absorbs: RMSE^2 ~ sigma^2 (3N - 6) / N.
  const size_t n = 3000;
  const double sigma = 0.01;
  const Trajectory groundtruth(LoopTrajectory(n, 30.0));
  std::mt19937 rng(42);
  std::normal_distribution<double> noise(0.0, sigma);
  std::vector<StampedPose> noisy = groundtruth.poses();
  for (StampedPose& pose : noisy) {
    pose.world_from_camera.translation() += Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
    pose.world_from_camera = KnownTransform() * pose.world_from_camera;
    pose.time += 0.005;  // within the 0.02 s association window
  }
  const AteResult ate = ComputeAte(groundtruth, Trajectory(noisy));
  const double expected = sigma * std::sqrt((3.0 * n - 6.0) / n);
  EXPECT_EQ(ate.translation.count, n);
  EXPECT_NEAR(ate.translation.rmse, expected, 0.03 * expected);
  // The alignment still recovers the transform to well under the noise.
  const Eigen::Isometry3d residual = ate.groundtruth_from_estimate * KnownTransform();
  EXPECT_LT(residual.translation().norm(), 2e-3);
  EXPECT_LT(Eigen::AngleAxisd(residual.linear()).angle(), 2e-3);
}

TEST(EvaluationTest, AssociationDropsPosesOutsideTheWindow) {
  const Trajectory groundtruth(LoopTrajectory(100, 10.0));
  std::vector<StampedPose> shifted = groundtruth.poses();
  for (size_t i = 0; i < shifted.size(); ++i) shifted[i].time += (i % 2 == 0) ? 0.01 : 0.03;
  const AteResult ate = ComputeAte(groundtruth, Trajectory(shifted));
  EXPECT_EQ(ate.translation.count, 50u);
}

TEST(EvaluationTest, RpeOfKnownSpeedAndTurnRateErrors) {
  // Ground truth moves at 1 m/s along x, or turns at 10 deg/s in place; the estimate at 1.1 m/s,
  // or 11 deg/s, 301 poses over 10 s. evaluate_rpe.py's pairs: i with j = i + 30 for i < 270;
  // from i = 270 on, j is the last pose and the pair is dropped. Every pair is then a full 1 s
  // apart, with 0.1 m (or 1 deg) of error.
  auto make = [](double speed, double turn_deg) {
    std::vector<StampedPose> poses;
    for (int i = 0; i <= 300; ++i) {
      const double t = i / 30.0;
      Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
      pose.translation() = Eigen::Vector3d(speed * t, 0, 0);
      pose.linear() = Eigen::AngleAxisd(turn_deg * M_PI / 180.0 * t, Eigen::Vector3d::UnitZ())
                          .toRotationMatrix();
      poses.push_back({t, pose});
    }
    return Trajectory(poses);
  };
  const RpeResult speed = ComputeRpe(make(1.0, 0.0), make(1.1, 0.0));
  EXPECT_EQ(speed.translation.count, 270u);
  EXPECT_NEAR(speed.translation.min, 0.1, 1e-9);
  EXPECT_NEAR(speed.translation.max, 0.1, 1e-9);
  EXPECT_NEAR(speed.rotation.max, 0.0, 1e-6);
  const RpeResult turn = ComputeRpe(make(0.0, 10.0), make(0.0, 11.0));
  EXPECT_EQ(turn.rotation.count, 270u);
  EXPECT_NEAR(turn.rotation.min, 1.0, 1e-6);
  EXPECT_NEAR(turn.rotation.max, 1.0, 1e-6);
  EXPECT_NEAR(turn.translation.max, 0.0, 1e-9);
}

// Shorter than the delta, every pair would end on the last pose: no RPE, and the message says why.
TEST(EvaluationTest, RpeOfATrajectoryShorterThanTheDeltaSaysSo) {
  const Trajectory short_one(LoopTrajectory(10, 30.0));  // 0.3 s
  const std::string message = testing::ErrorOf([&] { ComputeRpe(short_one, short_one); });
  EXPECT_NE(message.find("lower the delta"), std::string::npos) << message;
  RpeOptions options;
  options.delta = 0.1;
  EXPECT_EQ(ComputeRpe(short_one, short_one, options).translation.count, 6u);  // i = 0..5
}

}  // namespace
}  // namespace stillmap
