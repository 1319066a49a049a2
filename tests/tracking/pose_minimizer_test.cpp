#include "pose_minimizer.h"

#include <ceres/ceres.h>
#include <gtest/gtest.h>

#include <cmath>
#include <deque>
#include <random>
#include <vector>

#include "pose_manifold.h"

namespace stillmap::internal {
namespace {

// The reference: the same cost as a Ceres problem, one residual block per observation, solved
// with the options the pose refinement used before it had its own minimizer.
class ReferenceCost : public ceres::SizedCostFunction<3, 7> {
 public:
  ReferenceCost(const Eigen::Vector3d& point, const RgbdObservation& observation)
      : point_(point), observation_(observation) {}

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    Eigen::Vector3d r;
    Eigen::Matrix<double, 3, 6> j;
    const bool want_jacobian = jacobians != nullptr && jacobians[0] != nullptr;
    if (!EvaluateRgbdResidual(PoseFromParameters(parameters[0]), point_, observation_, &r,
                              want_jacobian ? &j : nullptr)) {
      return false;
    }
    Eigen::Map<Eigen::Vector3d> residual_out(residuals);
    residual_out = r;
    if (want_jacobian) {
      Eigen::Map<Eigen::Matrix<double, 3, 7, Eigen::RowMajor>> out(jacobians[0]);
      out.leftCols<6>() = j;
      out.col(6).setZero();
    }
    return true;
  }

 private:
  Eigen::Vector3d point_;
  RgbdObservation observation_;
};

void SolveWithCeres(const std::vector<Eigen::Vector3d>& points,
                    const std::vector<RgbdObservation>& observations,
                    const std::vector<double>& huber_scales, const std::vector<bool>& active,
                    int max_iterations, double* pose) {
  ceres::Problem problem;
  problem.AddParameterBlock(pose, 7, new PoseManifold);
  for (size_t i = 0; i < points.size(); ++i) {
    if (!active[i]) continue;
    problem.AddResidualBlock(new ReferenceCost(points[i], observations[i]),
                             new ceres::HuberLoss(huber_scales[i]), pose);
  }
  ceres::Solver::Options options;
  options.linear_solver_type = ceres::DENSE_NORMAL_CHOLESKY;
  options.max_num_iterations = max_iterations;
  options.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(options, &problem, &summary);
}

// A random camera looking at `count` points 1-4 m away, with pixel and depth noise, a fifth of
// the observations wrong by up to 0.3 (normalized), a third without depth.
struct Scene {
  std::vector<Eigen::Vector3d> points;
  std::vector<RgbdObservation> observations;
  std::vector<double> huber_scales;
  std::vector<bool> active;
  Eigen::Isometry3d camera_from_world = Eigen::Isometry3d::Identity();
};

Scene RandomScene(unsigned seed, int count) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> lateral(-1.5, 1.5), depth(1.0, 4.0), wrong(-0.3, 0.3);
  std::normal_distribution<double> pixel_noise(0.0, 0.002), depth_noise(0.0, 0.01);
  Scene scene;
  scene.camera_from_world.linear() =
      Eigen::AngleAxisd(lateral(rng), Eigen::Vector3d(0.3, 1.0, 0.2).normalized())
          .toRotationMatrix();
  scene.camera_from_world.translation() = Eigen::Vector3d(lateral(rng), 0.5, lateral(rng));
  for (int i = 0; i < count; ++i) {
    const Eigen::Vector3d in_camera(lateral(rng), lateral(rng), depth(rng));
    scene.points.push_back(scene.camera_from_world.inverse() * in_camera);
    RgbdObservation observation;
    observation.normalized =
        in_camera.head<2>() / in_camera.z() + Eigen::Vector2d(pixel_noise(rng), pixel_noise(rng));
    if (i % 5 == 4) observation.normalized += Eigen::Vector2d(wrong(rng), wrong(rng));
    observation.depth_m = i % 3 == 0 ? 0.0 : in_camera.z() + depth_noise(rng);
    observation.sigma_inverse_depth = 0.003;
    scene.observations.push_back(observation);
    scene.huber_scales.push_back(std::sqrt(observation.depth_m > 0.0 ? 7.815 : 5.991));
    scene.active.push_back(i % 7 != 6);  // some switched off, as between refinement rounds
  }
  return scene;
}

// The start: the true pose moved by up to 0.1 rad and 0.1 m.
void PerturbedStart(const Scene& scene, unsigned seed, double* pose) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> move(-0.1, 0.1);
  Eigen::Isometry3d start = scene.camera_from_world;
  start.linear() =
      Eigen::AngleAxisd(move(rng), Eigen::Vector3d(move(rng), move(rng), 1.0).normalized())
          .toRotationMatrix() *
      start.linear();
  start.translation() += Eigen::Vector3d(move(rng), move(rng), move(rng));
  PoseToParameters(start, pose);
}

TEST(PoseMinimizerTest, TakesTheStepsCeresTakes) {
  int compared = 0;
  for (unsigned seed = 1; seed <= 12; ++seed) {
    const Scene scene = RandomScene(seed, 60 + 40 * static_cast<int>(seed % 4));
    PoseCost cost(scene.points, scene.observations, scene.huber_scales);
    cost.set_active(scene.active);
    for (int iterations : {1, 2, 4, 10, 50}) {
      double ours[7], ceres[7];
      PerturbedStart(scene, seed, ours);
      PerturbedStart(scene, seed, ceres);
      MinimizePose(cost, iterations, ours);
      SolveWithCeres(scene.points, scene.observations, scene.huber_scales, scene.active, iterations,
                     ceres);
      for (int k = 0; k < 7; ++k) {
        EXPECT_NEAR(ours[k], ceres[k], 1e-12)
            << "seed " << seed << ", " << iterations << " iterations, parameter " << k;
      }
      ++compared;
    }
  }
  EXPECT_EQ(compared, 60);
}

TEST(PoseMinimizerTest, LeavesAPoseItCannotEvaluate) {
  Scene scene = RandomScene(3, 40);
  PoseCost cost(scene.points, scene.observations, scene.huber_scales);
  double pose[7];
  PoseToParameters(scene.camera_from_world, pose);
  pose[6] -= 10.0;  // every point behind the camera
  double before[7];
  std::copy(pose, pose + 7, before);
  MinimizePose(cost, 10, pose);
  for (int k = 0; k < 7; ++k) EXPECT_EQ(pose[k], before[k]);
}

}  // namespace
}  // namespace stillmap::internal
