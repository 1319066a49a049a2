#include "stillmap/tracking/pose_refinement.h"

#include <ceres/ceres.h>

#include <algorithm>
#include <cmath>
#include <deque>
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

// An observation whose residual can be switched off (zero residual and Jacobian) between rounds,
// so that one Ceres problem serves every round.
class RgbdCost : public ceres::SizedCostFunction<3, 7> {
 public:
  RgbdCost(const Eigen::Vector3d& point_in_world, const RgbdObservation& observation)
      : point_in_world_(point_in_world), observation_(observation) {}

  void set_active(bool active) { active_ = active; }

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    Eigen::Map<Eigen::Vector3d> residual_out(residuals);
    const bool want_jacobian = jacobians != nullptr && jacobians[0] != nullptr;
    if (!active_) {
      residual_out.setZero();
      if (want_jacobian) std::fill(jacobians[0], jacobians[0] + 21, 0.0);
      return true;
    }
    const Eigen::Isometry3d camera_from_world = PoseFromParameters(parameters[0]);
    Eigen::Vector3d r;
    Eigen::Matrix<double, 3, 6> j;
    if (!EvaluateRgbdResidual(camera_from_world, point_in_world_, observation_, &r,
                              want_jacobian ? &j : nullptr)) {
      return false;  // behind the camera: Ceres shortens the step
    }
    residual_out = r;
    if (want_jacobian) {
      Eigen::Map<Eigen::Matrix<double, 3, 7, Eigen::RowMajor>> out(jacobians[0]);
      out.leftCols<6>() = j;
      out.col(6).setZero();
    }
    return true;
  }

 private:
  Eigen::Vector3d point_in_world_;
  RgbdObservation observation_;
  bool active_ = true;
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
  // One problem for all rounds: costs and losses live here (Ceres does not own them); outliers
  // are switched off rather than removed, and may come back after a later round.
  static PoseManifold manifold;
  ceres::HuberLoss loss_without_depth(std::sqrt(options.chi2_without_depth));
  ceres::HuberLoss loss_with_depth(std::sqrt(options.chi2_with_depth));
  std::deque<RgbdCost> costs;  // not movable: a deque never moves its elements
  ceres::Problem::Options problem_options;
  problem_options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  problem_options.cost_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  problem_options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(problem_options);
  problem.AddParameterBlock(pose, 7, &manifold);
  for (size_t i = 0; i < n; ++i) {
    costs.emplace_back(points_in_world[i], observations[i]);
    problem.AddResidualBlock(&costs.back(),
                             observations[i].depth_m > 0.0 ? &loss_with_depth : &loss_without_depth,
                             pose);
  }
  ceres::Solver::Options solver_options;
  solver_options.linear_solver_type = ceres::DENSE_NORMAL_CHOLESKY;  // 6 unknowns
  solver_options.max_num_iterations = options.iterations_per_round;
  solver_options.logging_type = ceres::SILENT;
  std::vector<bool> inlier(n, true);
  for (int round = 0; round < options.rounds; ++round) {
    const auto used = std::count(inlier.begin(), inlier.end(), true);
    if (used < options.min_inliers) break;
    for (size_t i = 0; i < n; ++i) costs[i].set_active(inlier[i]);
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
