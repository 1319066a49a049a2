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

// `count` points in front of TruePose()'s camera, drawn from `rng`, with their observations:
// the exact projection, which `observe` (point index, camera-frame point, observation) may change,
// drawing any noise from the same `rng`.
template <typename Observe>
void RandomScene(std::mt19937* rng, int count, const Observe& observe,
                 std::vector<Eigen::Vector3d>* points, std::vector<RgbdObservation>* observations) {
  std::uniform_real_distribution<double> lateral(-1.5, 1.5), depth(1.0, 4.0);
  const Eigen::Isometry3d camera_from_world = TruePose();
  for (int i = 0; i < count; ++i) {
    const Eigen::Vector3d in_camera(lateral(*rng), lateral(*rng), depth(*rng));
    points->push_back(camera_from_world.inverse() * in_camera);
    RgbdObservation observation;
    observation.normalized = in_camera.head<2>() / in_camera.z();
    observe(i, in_camera, &observation);
    observations->push_back(observation);
  }
}

TEST(PoseRefinementTest, ConvergesFromAPerturbedPoseAndFlagsOutliers) {
  std::mt19937 rng(8);
  std::uniform_real_distribution<double> wrong(-0.5, 0.5);
  const Eigen::Isometry3d camera_from_world = TruePose();
  std::vector<Eigen::Vector3d> points;
  std::vector<RgbdObservation> observations;
  RandomScene(
      &rng, 200,
      [&](int i, const Eigen::Vector3d& in_camera, RgbdObservation* observation) {
        observation->depth_m = i % 4 == 0 ? 0.0 : in_camera.z();  // a quarter without depth
        if (i % 10 == 9) observation->normalized += Eigen::Vector2d(wrong(rng), wrong(rng));
      },
      &points, &observations);
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

// The robust cost RefinePose minimizes, recomputed here from its definition: 1/2 sum of Huber's
// rho(|r|^2) with scale sqrt(chi2) over `used`.
double RobustCost(const Eigen::Isometry3d& camera_from_world,
                  const std::vector<Eigen::Vector3d>& points,
                  const std::vector<RgbdObservation>& observations, const std::vector<int>& used) {
  const RefinementOptions options;
  double cost = 0.0;
  for (int i : used) {
    const RgbdObservation& observation = observations[static_cast<size_t>(i)];
    const Eigen::Vector3d q = camera_from_world * points[static_cast<size_t>(i)];
    Eigen::Vector3d r((q.x() / q.z() - observation.normalized.x()) / observation.sigma_normalized,
                      (q.y() / q.z() - observation.normalized.y()) / observation.sigma_normalized,
                      0.0);
    double chi2 = options.chi2_without_depth;
    if (observation.depth_m > 0.0) {
      r.z() = (1.0 / q.z() - 1.0 / observation.depth_m) / observation.sigma_inverse_depth;
      chi2 = options.chi2_with_depth;
    }
    const double s = r.squaredNorm();
    cost += 0.5 * (s <= chi2 ? s : 2.0 * std::sqrt(chi2 * s) - chi2);
  }
  return cost;
}

// With noisy observations the refined pose is no longer the true one: it must be a minimum of
// the robust cost over its inliers. Every small move of the pose (central differences along the
// six axes) raises the cost recomputed here.
TEST(PoseRefinementTest, EndsAtAMinimumOfTheRobustCost) {
  std::mt19937 rng(11);
  std::normal_distribution<double> pixel_noise(0.0, 1.0 / 525), depth_noise(0.0, 0.01);
  const Eigen::Isometry3d camera_from_world = TruePose();
  std::vector<Eigen::Vector3d> points;
  std::vector<RgbdObservation> observations;
  RandomScene(
      &rng, 300,
      [&](int i, const Eigen::Vector3d& in_camera, RgbdObservation* observation) {
        observation->normalized += Eigen::Vector2d(pixel_noise(rng), pixel_noise(rng));
        observation->depth_m = i % 3 == 0 ? 0.0 : in_camera.z() + depth_noise(rng);
        observation->sigma_inverse_depth = 0.003;
      },
      &points, &observations);
  Eigen::Isometry3d start = camera_from_world;
  start.translation() += Eigen::Vector3d(-0.03, 0.02, 0.01);
  const PoseResult result = RefinePose(start, points, observations);
  ASSERT_TRUE(result.ok());
  ExpectSamePose(result.camera_from_world, camera_from_world, 0.01);
  const double at_result =
      RobustCost(result.camera_from_world, points, observations, result.inliers);
  for (int axis = 0; axis < 6; ++axis) {
    for (double sign : {-1.0, 1.0}) {
      Eigen::Isometry3d moved = result.camera_from_world;
      const double step = sign * 1e-4;
      if (axis < 3) {
        moved.linear() = Eigen::AngleAxisd(step, Eigen::Vector3d::Unit(axis)).toRotationMatrix() *
                         moved.linear();
      } else {
        moved.translation()(axis - 3) += step;
      }
      EXPECT_GT(RobustCost(moved, points, observations, result.inliers), at_result)
          << "axis " << axis << " step " << step;
    }
  }
}

TEST(PoseEstimationTest, TooFewPointsIsAStatusNotAPose) {
  const PoseResult result = EstimatePosePnp({{0, 0, 1}, {1, 0, 1}}, {{0, 0}, {1, 0}});
  EXPECT_FALSE(result.ok());
  EXPECT_EQ(result.status, PoseStatus::kTooFewPoints);
}

}  // namespace
}  // namespace stillmap
