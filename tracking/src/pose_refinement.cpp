#include "stillmap/tracking/pose_refinement.h"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>

namespace stillmap {
namespace {

// The chi-square threshold of an observation: 3 dof with a depth reading, 2 without.
double ChiSquareThreshold(const RgbdObservation& observation, const RefinementOptions& options) {
  return observation.depth_m > 0.0 ? options.chi2_with_depth : options.chi2_without_depth;
}

// camera_from_world moved by the tangent step [w v] of EvaluateRgbdResidual's Jacobian:
// q' = exp(w^) (R p + t) + v (PoseManifold::Plus, on the rotation matrix).
Eigen::Isometry3d Moved(const Eigen::Isometry3d& camera_from_world,
                        const Eigen::Matrix<double, 6, 1>& step) {
  const Eigen::Vector3d w = step.head<3>();
  const double angle = w.norm();
  const Eigen::Matrix3d rotation =
      angle > 1e-12 ? Eigen::AngleAxisd(angle, w / angle).toRotationMatrix()
                    : Eigen::Quaterniond(1.0, 0.5 * w.x(), 0.5 * w.y(), 0.5 * w.z())
                          .normalized()
                          .toRotationMatrix();
  Eigen::Isometry3d moved = Eigen::Isometry3d::Identity();
  moved.linear() = rotation * camera_from_world.linear();
  moved.translation() = rotation * camera_from_world.translation() + step.tail<3>();
  return moved;
}

// The Huber-robustified cost of the active observations at one pose, with the normal equations
// of its Gauss-Newton step (each residual and Jacobian weighted by the loss's slope, as Ceres'
// corrector does for a loss with no curvature).
struct Linearization {
  bool valid = true;  // every active point lies in front of the camera
  double cost = 0.0;  // 1/2 sum of rho(|r|^2)
  Eigen::Matrix<double, 6, 6> hessian = Eigen::Matrix<double, 6, 6>::Zero();
  Eigen::Matrix<double, 6, 1> gradient = Eigen::Matrix<double, 6, 1>::Zero();
};

class PoseProblem {
 public:
  PoseProblem(const std::vector<Eigen::Vector3d>& points,
              const std::vector<RgbdObservation>& observations, const RefinementOptions& options)
      : points_(points), observations_(observations) {
    for (const RgbdObservation& observation : observations) {
      huber_.push_back(std::sqrt(ChiSquareThreshold(observation, options)));
    }
  }

  // The cost at `camera_from_world` of the observations flagged in `active`; with
  // `with_equations`, the normal equations too.
  Linearization Evaluate(const Eigen::Isometry3d& camera_from_world,
                         const std::vector<bool>& active, bool with_equations) const {
    Linearization out;
    Eigen::Vector3d r;
    Eigen::Matrix<double, 3, 6> j;
    for (size_t i = 0; i < points_.size(); ++i) {
      if (!active[i]) continue;
      if (!EvaluateRgbdResidual(camera_from_world, points_[i], observations_[i], &r,
                                with_equations ? &j : nullptr)) {
        out.valid = false;
        return out;
      }
      const double squared = r.squaredNorm(), delta = huber_[i];
      const bool inner = squared <= delta * delta;
      const double root = std::sqrt(squared);
      out.cost += 0.5 * (inner ? squared : 2.0 * delta * root - delta * delta);
      if (!with_equations) continue;
      const double weight = inner ? 1.0 : delta / root;  // rho'(|r|^2)
      out.hessian.noalias() += weight * j.transpose() * j;
      out.gradient.noalias() += weight * j.transpose() * r;
    }
    return out;
  }

 private:
  const std::vector<Eigen::Vector3d>& points_;
  const std::vector<RgbdObservation>& observations_;
  std::vector<double> huber_;  // the Huber loss's scale per observation
};

// Levenberg-Marquardt over the pose (Ceres' defaults: Marquardt's diagonal damping starting at
// 1e-4, its update of the damping from the gain ratio, tolerances 1e-6 on the cost's relative
// decrease and 1e-8 on the step). A pose has 6 unknowns: Ceres' set-up per solve (program,
// evaluator, checks) cost more than the solve itself at a few hundred residuals (perf: 3 % of a
// bonn_crowd_a build; BM_RefinePose).
Eigen::Isometry3d Minimize(const PoseProblem& problem, const Eigen::Isometry3d& start,
                           const std::vector<bool>& active, int max_iterations) {
  Eigen::Isometry3d pose = start;
  Linearization current = problem.Evaluate(pose, active, true);
  if (!current.valid) return pose;  // Ceres, too, leaves a pose it cannot evaluate
  double damping = 1e-4, growth = 2.0;
  for (int iteration = 0; iteration < max_iterations; ++iteration) {
    if (current.gradient.lpNorm<Eigen::Infinity>() <= 1e-10) break;
    const Eigen::Matrix<double, 6, 1> diagonal =
        current.hessian.diagonal().cwiseMax(1e-6).cwiseMin(1e32);
    Eigen::Matrix<double, 6, 6> damped = current.hessian;
    damped.diagonal() += damping * diagonal;
    const Eigen::Matrix<double, 6, 1> step = damped.ldlt().solve(-current.gradient);
    if (!step.allFinite()) break;
    const Eigen::Isometry3d candidate = Moved(pose, step);
    const Linearization next = problem.Evaluate(candidate, active, true);
    // Model decrease of the damped Gauss-Newton step: -g.s - 1/2 s.H.s.
    const double predicted = -current.gradient.dot(step) - 0.5 * step.dot(current.hessian * step);
    // Accepted when the cost fell by at least 1e-3 of the model's promise (Ceres'
    // min_relative_decrease).
    if (!next.valid || !(predicted > 0.0) || !((current.cost - next.cost) / predicted > 1e-3)) {
      damping *= growth;
      growth *= 2.0;
      continue;
    }
    const double gain = (current.cost - next.cost) / predicted;
    damping *= std::max(1.0 / 3.0, 1.0 - std::pow(2.0 * gain - 1.0, 3));
    growth = 2.0;
    // The parameters' norm: the unit quaternion's and the translation's.
    const double size = std::sqrt(1.0 + pose.translation().squaredNorm());
    const bool small_step = step.norm() <= 1e-8 * (size + 1e-8);
    const bool small_decrease = (current.cost - next.cost) <= 1e-6 * current.cost;
    pose = candidate;
    current = next;
    if (small_step || small_decrease) break;
  }
  return pose;
}

}  // namespace

PoseResult RefinePose(const Eigen::Isometry3d& initial,
                      const std::vector<Eigen::Vector3d>& points_in_world,
                      const std::vector<RgbdObservation>& observations,
                      const RefinementOptions& options) {
  PoseResult result;
  result.camera_from_world = initial;
  const size_t n = points_in_world.size();
  if (n < static_cast<size_t>(options.min_inliers) || observations.size() != n) return result;
  const PoseProblem problem(points_in_world, observations, options);
  Eigen::Isometry3d pose = initial;
  std::vector<bool> inlier(n, true);
  for (int round = 0; round < options.rounds; ++round) {
    const auto used = std::count(inlier.begin(), inlier.end(), true);
    if (used < options.min_inliers) break;
    pose = Minimize(problem, pose, inlier, options.iterations_per_round);
    // Reclassify every observation against the refined pose (outliers may come back).
    for (size_t i = 0; i < n; ++i) {
      Eigen::Vector3d r;
      inlier[i] = EvaluateRgbdResidual(pose, points_in_world[i], observations[i], &r, nullptr) &&
                  r.squaredNorm() < ChiSquareThreshold(observations[i], options);
    }
  }
  result.camera_from_world = pose;
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
