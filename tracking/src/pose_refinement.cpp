#include "stillmap/tracking/pose_refinement.h"

#include <ceres/ceres.h>

#include <cmath>
#include <utility>

#include "pose_manifold.h"

namespace stillmap {
namespace {

using internal::PoseFromParameters;
using internal::PoseManifold;
using internal::PoseToParameters;

// The chi-square threshold of an observation: 3 dof with a depth reading, 2 without.
double ChiSquareThreshold(const RgbdObservation& observation, const RefinementOptions& options) {
  return observation.depth_m > 0.0 ? options.chi2_with_depth : options.chi2_without_depth;
}

class RgbdCost : public ceres::SizedCostFunction<3, 7> {
 public:
  RgbdCost(Eigen::Vector3d point_in_world, RgbdObservation observation)
      : point_in_world_(std::move(point_in_world)), observation_(std::move(observation)) {}

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    const Eigen::Isometry3d camera_from_world = PoseFromParameters(parameters[0]);
    Eigen::Vector3d r;
    Eigen::Matrix<double, 3, 6> j;
    if (!EvaluateRgbdResidual(camera_from_world, point_in_world_, observation_, &r,
                              jacobians != nullptr && jacobians[0] != nullptr ? &j : nullptr)) {
      return false;  // behind the camera: Ceres shortens the step
    }
    Eigen::Map<Eigen::Vector3d> residual_out(residuals);
    residual_out = r;
    if (jacobians != nullptr && jacobians[0] != nullptr) {
      Eigen::Map<Eigen::Matrix<double, 3, 7, Eigen::RowMajor>> out(jacobians[0]);
      out.leftCols<6>() = j;
      out.col(6).setZero();
    }
    return true;
  }

 private:
  Eigen::Vector3d point_in_world_;
  RgbdObservation observation_;
};

}  // namespace

PoseResult RefinePose(const Eigen::Isometry3d& initial,
                      const std::vector<Eigen::Vector3d>& points_in_world,
                      const std::vector<RgbdObservation>& observations,
                      const RefinementOptions& options) {
  PoseResult result;
  result.camera_from_world = initial;
  const size_t n = points_in_world.size();
  if (n < static_cast<size_t>(options.min_inliers) || observations.size() != n) return result;
  double pose[7];
  PoseToParameters(initial, pose);
  std::vector<bool> inlier(n, true);
  for (int round = 0; round < options.rounds; ++round) {
    ceres::Problem::Options problem_options;
    problem_options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    static PoseManifold manifold;
    ceres::Problem problem(problem_options);
    problem.AddParameterBlock(pose, 7, &manifold);
    int used = 0;
    for (size_t i = 0; i < n; ++i) {
      if (!inlier[i]) continue;
      problem.AddResidualBlock(
          new RgbdCost(points_in_world[i], observations[i]),
          new ceres::HuberLoss(std::sqrt(ChiSquareThreshold(observations[i], options))), pose);
      ++used;
    }
    if (used < options.min_inliers) break;
    ceres::Solver::Options solver_options;
    solver_options.linear_solver_type = ceres::DENSE_QR;
    solver_options.max_num_iterations = options.iterations_per_round;
    solver_options.logging_type = ceres::SILENT;
    ceres::Solver::Summary summary;
    ceres::Solve(solver_options, &problem, &summary);
    // Reclassify every observation against the refined pose (outliers may come back).
    const Eigen::Isometry3d camera_from_world = PoseFromParameters(pose);
    for (size_t i = 0; i < n; ++i) {
      Eigen::Vector3d r;
      inlier[i] = EvaluateRgbdResidual(camera_from_world, points_in_world[i], observations[i], &r,
                                       nullptr) &&
                  r.squaredNorm() < ChiSquareThreshold(observations[i], options);
    }
  }
  result.camera_from_world = PoseFromParameters(pose);
  double sum = 0.0;
  for (size_t i = 0; i < n; ++i) {
    if (!inlier[i]) continue;
    result.inliers.push_back(static_cast<int>(i));
    const Eigen::Vector3d q = result.camera_from_world * points_in_world[i];
    sum += (q.head<2>() / q.z() - observations[i].normalized).squaredNorm();
  }
  result.status = static_cast<int>(result.inliers.size()) >= options.min_inliers
                      ? PoseStatus::kOk
                      : PoseStatus::kTooFewInliers;
  if (!result.inliers.empty()) {
    result.reprojection_rmse = std::sqrt(sum / static_cast<double>(result.inliers.size()));
  }
  return result;
}

}  // namespace stillmap
