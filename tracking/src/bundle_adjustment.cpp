#include "stillmap/tracking/bundle_adjustment.h"

#include <ceres/ceres.h>

#include <cmath>

#include "pose_manifold.h"

namespace stillmap {
namespace {

using internal::PoseFromParameters;
using internal::PoseManifold;
using internal::PoseToParameters;

double ChiSquareThreshold(const RgbdObservation& observation,
                          const BundleAdjustmentOptions& options) {
  return observation.depth_m > 0.0 ? options.chi2_with_depth : options.chi2_without_depth;
}

// One observation: parameters [pose (7)], [landmark (3)]. The landmark Jacobian is the residual's
// derivative with respect to the point in the camera frame (the translation columns of the pose
// Jacobian) times the rotation.
class BundleCost : public ceres::SizedCostFunction<3, 7, 3> {
 public:
  explicit BundleCost(const RgbdObservation& observation) : observation_(observation) {}

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    const Eigen::Isometry3d camera_from_world = PoseFromParameters(parameters[0]);
    const Eigen::Map<const Eigen::Vector3d> point(parameters[1]);
    const bool want_jacobian =
        jacobians != nullptr && (jacobians[0] != nullptr || jacobians[1] != nullptr);
    Eigen::Vector3d r;
    Eigen::Matrix<double, 3, 6> j;
    if (!EvaluateRgbdResidual(camera_from_world, point, observation_, &r,
                              want_jacobian ? &j : nullptr)) {
      return false;
    }
    Eigen::Map<Eigen::Vector3d> residual_out(residuals);
    residual_out = r;
    if (want_jacobian && jacobians[0] != nullptr) {
      Eigen::Map<Eigen::Matrix<double, 3, 7, Eigen::RowMajor>> out(jacobians[0]);
      out.leftCols<6>() = j;
      out.col(6).setZero();
    }
    if (want_jacobian && jacobians[1] != nullptr) {
      Eigen::Map<Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> out(jacobians[1]);
      out = j.rightCols<3>() * camera_from_world.linear();
    }
    return true;
  }

 private:
  RgbdObservation observation_;
};

}  // namespace

BundleAdjustmentResult SolveBundleAdjustment(const BundleAdjustmentProblem& problem,
                                             const BundleAdjustmentOptions& options) {
  const size_t keyframe_count = problem.keyframes.size();
  std::vector<double> poses(7 * keyframe_count);
  for (size_t k = 0; k < keyframe_count; ++k) {
    PoseToParameters(problem.keyframes[k].camera_from_world, &poses[7 * k]);
  }
  std::vector<double> points(3 * problem.landmarks.size());
  for (size_t i = 0; i < problem.landmarks.size(); ++i) {
    Eigen::Map<Eigen::Vector3d> point(&points[3 * i]);
    point = problem.landmarks[i];
  }
  BundleAdjustmentResult result;
  result.outlier.assign(problem.observations.size(), false);

  static PoseManifold manifold;
  for (int round = 0; round < 2; ++round) {
    ceres::Problem::Options problem_options;
    problem_options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    ceres::Problem ceres_problem(problem_options);
    int residual_count = 0;
    for (size_t o = 0; o < problem.observations.size(); ++o) {
      if (result.outlier[o]) continue;
      const BundleAdjustmentObservation& observation = problem.observations[o];
      double* pose = &poses[7 * static_cast<size_t>(observation.keyframe)];
      double* point = &points[3 * static_cast<size_t>(observation.landmark)];
      // Round one is robust (Huber); round two runs on the inliers only, like ORB-SLAM2.
      ceres::LossFunction* loss = round == 0 ? new ceres::HuberLoss(std::sqrt(ChiSquareThreshold(
                                                   observation.observation, options)))
                                             : nullptr;
      ceres_problem.AddResidualBlock(new BundleCost(observation.observation), loss, pose, point);
      ++residual_count;
    }
    if (residual_count == 0) break;
    for (size_t k = 0; k < keyframe_count; ++k) {
      double* pose = &poses[7 * k];
      if (!ceres_problem.HasParameterBlock(pose)) continue;
      ceres_problem.SetManifold(pose, &manifold);
      if (problem.keyframes[k].fixed) ceres_problem.SetParameterBlockConstant(pose);
    }
    ceres::Solver::Options solver_options;
    // A few poses and many points: the Schur complement leaves a small dense camera system.
    solver_options.linear_solver_type = ceres::DENSE_SCHUR;
    solver_options.max_num_iterations =
        round == 0 ? options.iterations_first : options.iterations_second;
    solver_options.logging_type = ceres::SILENT;
    solver_options.num_threads = 1;
    ceres::Solver::Summary summary;
    ceres::Solve(solver_options, &ceres_problem, &summary);
    if (round == 0) result.initial_cost = summary.initial_cost;
    result.final_cost = summary.final_cost;
    result.iterations += static_cast<int>(summary.iterations.size());

    // Classify every observation against the current estimate.
    for (size_t o = 0; o < problem.observations.size(); ++o) {
      const BundleAdjustmentObservation& observation = problem.observations[o];
      const Eigen::Isometry3d camera_from_world =
          PoseFromParameters(&poses[7 * static_cast<size_t>(observation.keyframe)]);
      const Eigen::Map<const Eigen::Vector3d> point(
          &points[3 * static_cast<size_t>(observation.landmark)]);
      Eigen::Vector3d r;
      result.outlier[o] =
          !EvaluateRgbdResidual(camera_from_world, point, observation.observation, &r, nullptr) ||
          r.squaredNorm() > ChiSquareThreshold(observation.observation, options);
    }
  }
  result.camera_from_world.reserve(keyframe_count);
  for (size_t k = 0; k < keyframe_count; ++k) {
    result.camera_from_world.push_back(PoseFromParameters(&poses[7 * k]));
  }
  result.landmarks.reserve(problem.landmarks.size());
  for (size_t i = 0; i < problem.landmarks.size(); ++i) {
    result.landmarks.emplace_back(Eigen::Map<const Eigen::Vector3d>(&points[3 * i]));
  }
  return result;
}

}  // namespace stillmap
