#include "stillmap/tracking/rgbd_residual.h"

#include <gtest/gtest.h>

#include <random>

namespace stillmap {
namespace {

// The perturbation the Jacobian is defined for: q' = exp(w^) q + v.
Eigen::Isometry3d Perturbed(const Eigen::Isometry3d& camera_from_world,
                            const Eigen::Matrix<double, 6, 1>& delta) {
  Eigen::Isometry3d update = Eigen::Isometry3d::Identity();
  const Eigen::Vector3d w = delta.head<3>();
  if (w.norm() > 0.0)
    update.linear() = Eigen::AngleAxisd(w.norm(), w.normalized()).toRotationMatrix();
  update.translation() = delta.tail<3>();
  return update * camera_from_world;
}

TEST(RgbdResidualTest, AnalyticJacobianMatchesCentralDifferences) {
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  for (int trial = 0; trial < 50; ++trial) {
    Eigen::Isometry3d camera_from_world = Eigen::Isometry3d::Identity();
    camera_from_world.linear() =
        Eigen::AngleAxisd(unit(rng), Eigen::Vector3d(unit(rng), unit(rng), unit(rng)).normalized())
            .toRotationMatrix();
    camera_from_world.translation() = Eigen::Vector3d(unit(rng), unit(rng), unit(rng));
    const Eigen::Vector3d point_in_camera(unit(rng), unit(rng), 2.5 + unit(rng));
    const Eigen::Vector3d point_in_world = camera_from_world.inverse() * point_in_camera;
    RgbdObservation observation;
    observation.normalized = Eigen::Vector2d(0.1 * unit(rng), 0.1 * unit(rng));
    observation.depth_m = trial % 5 == 0 ? 0.0 : 2.0 + unit(rng);  // some without depth
    Eigen::Vector3d residual;
    Eigen::Matrix<double, 3, 6> analytic;
    ASSERT_TRUE(
        EvaluateRgbdResidual(camera_from_world, point_in_world, observation, &residual, &analytic));
    Eigen::Matrix<double, 3, 6> numeric;
    const double h = 1e-6;
    for (int k = 0; k < 6; ++k) {
      Eigen::Matrix<double, 6, 1> delta = Eigen::Matrix<double, 6, 1>::Zero();
      delta[k] = h;
      Eigen::Vector3d plus, minus;
      EvaluateRgbdResidual(Perturbed(camera_from_world, delta), point_in_world, observation, &plus,
                           nullptr);
      EvaluateRgbdResidual(Perturbed(camera_from_world, -delta), point_in_world, observation,
                           &minus, nullptr);
      numeric.col(k) = (plus - minus) / (2.0 * h);
    }
    EXPECT_LT((analytic - numeric).norm(), 1e-5 * std::max(1.0, analytic.norm()))
        << "trial " << trial << "\nanalytic\n"
        << analytic << "\nnumeric\n"
        << numeric;
    if (observation.depth_m == 0.0) {
      EXPECT_EQ(residual[2], 0.0);
    }
  }
}

TEST(RgbdResidualTest, ZeroAtTheTruePoseAndBehindTheCameraRefused) {
  const Eigen::Isometry3d camera_from_world = Eigen::Isometry3d::Identity();
  RgbdObservation observation;
  observation.normalized = Eigen::Vector2d(0.1, -0.2);
  observation.depth_m = 2.0;
  Eigen::Vector3d residual;
  ASSERT_TRUE(
      EvaluateRgbdResidual(camera_from_world, {0.2, -0.4, 2.0}, observation, &residual, nullptr));
  EXPECT_LT(residual.norm(), 1e-12);
  EXPECT_FALSE(
      EvaluateRgbdResidual(camera_from_world, {0.0, 0.0, -1.0}, observation, &residual, nullptr));
}

}  // namespace
}  // namespace stillmap
