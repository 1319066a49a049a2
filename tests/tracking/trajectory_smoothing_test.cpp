// The frames' poses smoothed, against exact truth: a camera whose position is a quadratic in time
// and which turns at a constant rate about a fixed axis is kept exactly as it is (the fits are
// exact for such motion); white noise on it comes down by the factor a least-squares quadratic
// over 2n + 1 equally spaced samples gives its centre, sqrt(3 (3n^2 + 3n - 1) / ((2n - 1)(2n + 1)
// (2n + 3))) (Savitzky and Golay 1964); and a jump where a run begins, or across a gap in time,
// is not spread over the frames beside it.
#include "stillmap/tracking/trajectory_smoothing.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace stillmap {
namespace {

constexpr double kRateHz = 30.0;

// The true camera at time t: along a parabola, turning 20 degrees a second about a tilted axis.
Eigen::Isometry3d TruePose(double t) {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.translation() = Eigen::Vector3d(0.3 + 0.5 * t + 0.4 * t * t, -0.2 * t + 0.1 * t * t, 1.1);
  pose.linear() =
      Eigen::AngleAxisd(20.0 * M_PI / 180.0 * t, Eigen::Vector3d(0.2, 1.0, 0.1).normalized())
          .toRotationMatrix();
  return pose;
}

std::vector<StampedPose> TruePath(size_t frames, double offset_m = 0.0, double start_s = 0.0) {
  std::vector<StampedPose> poses;
  for (size_t i = 0; i < frames; ++i) {
    const double t = start_s + static_cast<double>(i) / kRateHz;
    poses.push_back({t, TruePose(t)});
    poses.back().world_from_camera.translation().x() += offset_m;
  }
  return poses;
}

// How far apart two poses' cameras are [m].
double PositionError(const StampedPose& a, const StampedPose& b) {
  return (a.world_from_camera.translation() - b.world_from_camera.translation()).norm();
}

double AngleBetween(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return Eigen::AngleAxisd(a.linear().transpose() * b.linear()).angle();
}

TEST(TrajectorySmoothingTest, MotionOfConstantAccelerationAndTurnRateIsKeptExactly) {
  const std::vector<StampedPose> truth = TruePath(120);
  std::vector<StampedPose> poses = truth;
  const TrajectorySmoothingFigures figures =
      SmoothTrajectory(TrajectorySmoothingOptions(), std::vector<bool>(poses.size()), &poses);
  EXPECT_EQ(figures.runs, 1u);
  for (size_t i = 0; i < poses.size(); ++i) {
    EXPECT_NEAR(PositionError(poses[i], truth[i]), 0.0, 1e-9) << i;
    EXPECT_NEAR(AngleBetween(poses[i].world_from_camera, truth[i].world_from_camera), 0.0, 1e-9);
  }
  EXPECT_LT(figures.largest_move_m, 1e-9);
}

TEST(TrajectorySmoothingTest, WhiteNoiseComesDownAsTheQuadraticFitSays) {
  const std::vector<StampedPose> truth = TruePath(900);
  std::vector<StampedPose> poses = truth;
  std::mt19937 random(7);
  std::normal_distribution<double> position_noise(0.0, 0.005), angle_noise(0.0, 0.003);
  for (StampedPose& pose : poses) {
    pose.world_from_camera.translation() +=
        Eigen::Vector3d(position_noise(random), position_noise(random), position_noise(random));
    const Eigen::Vector3d turn(angle_noise(random), angle_noise(random), angle_noise(random));
    pose.world_from_camera.linear() =
        pose.world_from_camera.linear() *
        Eigen::AngleAxisd(turn.norm(), turn.normalized()).toRotationMatrix();
  }
  const std::vector<StampedPose> noisy = poses;
  TrajectorySmoothingOptions options;
  options.position_s = options.rotation_s = 0.2;  // 6 frames on either side at 30 Hz
  SmoothTrajectory(options, std::vector<bool>(poses.size()), &poses);
  const double n = 6.0;
  const double factor = std::sqrt(3.0 * (3.0 * n * n + 3.0 * n - 1.0) /
                                  ((2.0 * n - 1.0) * (2.0 * n + 1.0) * (2.0 * n + 3.0)));
  double before = 0.0, after = 0.0, turn_before = 0.0, turn_after = 0.0;
  size_t count = 0;
  for (size_t i = 6; i + 6 < poses.size(); ++i) {  // frames with their whole window
    const Eigen::Vector3d& exact = truth[i].world_from_camera.translation();
    before += (noisy[i].world_from_camera.translation() - exact).squaredNorm();
    after += (poses[i].world_from_camera.translation() - exact).squaredNorm();
    turn_before +=
        std::pow(AngleBetween(noisy[i].world_from_camera, truth[i].world_from_camera), 2);
    turn_after += std::pow(AngleBetween(poses[i].world_from_camera, truth[i].world_from_camera), 2);
    ++count;
  }
  const double ratio = std::sqrt(after / before), turn_ratio = std::sqrt(turn_after / turn_before);
  std::cout << "noise kept: positions " << ratio << ", rotations " << turn_ratio << " (expected "
            << factor << ")\n";
  EXPECT_NEAR(ratio, factor, 0.03);
  EXPECT_NEAR(turn_ratio, factor, 0.03);
}

TEST(TrajectorySmoothingTest, AJumpWhereARunBeginsOrAcrossAGapIsNotSpread) {
  // Two stretches of the path, the second 1 m off (a relocalization, a new segment), one frame
  // apart in time, then the same after a 1 s gap (lost frames) with no run start.
  std::vector<StampedPose> truth = TruePath(60);
  for (const StampedPose& pose : TruePath(60, 1.0, 2.0)) truth.push_back(pose);
  for (const StampedPose& pose : TruePath(60, 2.0, 5.0)) truth.push_back(pose);
  std::vector<bool> run_start(truth.size(), false);
  run_start[60] = true;
  std::vector<StampedPose> poses = truth;
  const TrajectorySmoothingFigures figures =
      SmoothTrajectory(TrajectorySmoothingOptions(), run_start, &poses);
  EXPECT_EQ(figures.runs, 3u);
  for (size_t i = 0; i < poses.size(); ++i) {
    EXPECT_NEAR(PositionError(poses[i], truth[i]), 0.0, 1e-9) << i;
  }
  // Without the run start the frames beside the first jump are pulled towards it.
  poses = truth;
  SmoothTrajectory(TrajectorySmoothingOptions(), std::vector<bool>(truth.size()), &poses);
  EXPECT_GT(PositionError(poses[59], truth[59]), 0.01);
}

TEST(TrajectorySmoothingTest, ARunsEndsAndAZeroWindowStayAsTracked) {
  std::vector<StampedPose> poses = TruePath(40);
  std::mt19937 random(3);
  std::normal_distribution<double> noise(0.0, 0.005);
  for (StampedPose& pose : poses) pose.world_from_camera.translation().x() += noise(random);
  const std::vector<StampedPose> noisy = poses;
  SmoothTrajectory(TrajectorySmoothingOptions(), std::vector<bool>(poses.size()), &poses);
  EXPECT_TRUE(poses.front().world_from_camera.isApprox(noisy.front().world_from_camera, 0.0));
  EXPECT_TRUE(poses.back().world_from_camera.isApprox(noisy.back().world_from_camera, 0.0));
  EXPECT_FALSE(poses[20].world_from_camera.isApprox(noisy[20].world_from_camera, 1e-6));

  TrajectorySmoothingOptions off;
  off.position_s = off.rotation_s = 0.0;
  poses = noisy;
  const TrajectorySmoothingFigures figures =
      SmoothTrajectory(off, std::vector<bool>(poses.size()), &poses);
  EXPECT_EQ(figures.frames_moved, 0u);
  for (size_t i = 0; i < poses.size(); ++i) {
    EXPECT_EQ(poses[i].world_from_camera.matrix(), noisy[i].world_from_camera.matrix());
  }
}

}  // namespace
}  // namespace stillmap
