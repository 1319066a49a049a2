#include "pose_minimizer.h"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include "pose_manifold.h"

namespace stillmap::internal {
namespace {

using Vector6 = Eigen::Matrix<double, 6, 1>;
using Vector7 = Eigen::Matrix<double, 7, 1>;
using Matrix6 = Eigen::Matrix<double, 6, 6>;

// Ceres 2.1's Solver::Options defaults, which the pose refinement always used.
constexpr double kFunctionTolerance = 1e-6;
constexpr double kGradientTolerance = 1e-10;
constexpr double kParameterTolerance = 1e-8;
constexpr double kMinRelativeDecrease = 1e-3;
constexpr double kInitialRadius = 1e4;
constexpr double kMaxRadius = 1e16;
constexpr double kMinRadius = 1e-32;
constexpr double kMinDiagonal = 1e-6;
constexpr double kMaxDiagonal = 1e32;
constexpr int kMaxConsecutiveInvalidSteps = 5;

// Levenberg-Marquardt's trust region: grown after an accepted step by the step's quality,
// shrunk by a growing factor after each rejected one (Ceres' LevenbergMarquardtStrategy).
struct TrustRegion {
  double radius = kInitialRadius;
  double decrease_factor = 2.0;

  void Accept(double quality) {
    radius /= std::max(1.0 / 3.0, 1.0 - std::pow(2.0 * quality - 1.0, 3));
    radius = std::min(kMaxRadius, radius);
    decrease_factor = 2.0;
  }
  void Reject() {
    radius /= decrease_factor;
    decrease_factor *= 2.0;
  }
};

// The gradient's size as Ceres measures it: |x - Plus(x, -gradient)|, max norm.
double ProjectedGradientNorm(const PoseManifold& manifold, const Vector7& x,
                             const Vector6& gradient) {
  const Vector6 descent = -gradient;
  Vector7 moved;
  manifold.Plus(x.data(), descent.data(), moved.data());
  return (x - moved).lpNorm<Eigen::Infinity>();
}

}  // namespace

PoseCost::PoseCost(const std::vector<Eigen::Vector3d>& points_in_world,
                   const std::vector<RgbdObservation>& observations,
                   std::vector<double> huber_scales)
    : points_(points_in_world),
      observations_(observations),
      huber_(std::move(huber_scales)),
      active_(points_in_world.size(), true) {}

bool PoseCost::Evaluate(const double* x, double* cost, Eigen::Matrix<double, 6, 6>* hessian,
                        Eigen::Matrix<double, 6, 1>* gradient) const {
  const Eigen::Isometry3d camera_from_world = PoseFromParameters(x);
  const bool derivatives = hessian != nullptr && gradient != nullptr;
  if (derivatives) {
    hessian->setZero();
    gradient->setZero();
  }
  double sum = 0.0;
  Eigen::Vector3d r;
  Eigen::Matrix<double, 3, 6> j;
  for (size_t i = 0; i < points_.size(); ++i) {
    if (!active_[i]) continue;
    if (!EvaluateRgbdResidual(camera_from_world, points_[i], observations_[i], &r,
                              derivatives ? &j : nullptr)) {
      return false;
    }
    // Huber: rho(s) = s inside delta^2, 2 delta sqrt(s) - delta^2 outside (ceres::HuberLoss).
    const double squared = r.squaredNorm(), delta = huber_[i];
    double rho = squared, slope = 1.0;
    if (squared > delta * delta) {
      const double root = std::sqrt(squared);
      rho = 2.0 * delta * root - delta * delta;
      slope = std::max(std::numeric_limits<double>::min(), delta / root);
    }
    sum += 0.5 * rho;
    if (!derivatives) continue;
    const double weight = std::sqrt(slope);
    r *= weight;
    j *= weight;
    hessian->noalias() += j.transpose() * j;
    gradient->noalias() += j.transpose() * r;
  }
  *cost = sum;
  return true;
}

// Ceres' TrustRegionMinimizer with LevenbergMarquardtStrategy and a dense normal-equations solve,
// in the same order of tests: Jacobi scaling fixed at the first Jacobian, Marquardt's diagonal
// clamped and reused after a rejected step, a step that stops the solve on the parameter or cost
// tolerance is not taken, and the parameter tolerance does not apply before the first accepted
// step. Results match a Ceres solve up to rounding (PoseMinimizerTest); a pose has six unknowns,
// where Ceres' set-up per solve cost more than the solve (BM_RefinePose 0.78 -> 0.27 ms).
void MinimizePose(const PoseCost& cost, int max_iterations, double* x_inout) {
  const PoseManifold manifold;
  Vector7 x = Eigen::Map<const Vector7>(x_inout);
  double x_cost = 0.0;
  Matrix6 hessian;
  Vector6 gradient;
  if (!cost.Evaluate(x.data(), &x_cost, &hessian, &gradient)) return;
  const Vector6 scaling = (1.0 + hessian.diagonal().array().sqrt()).inverse().matrix();
  double x_norm = -1.0;  // Ceres' value until the first accepted step
  TrustRegion region;
  Vector6 diagonal;
  bool accepted = true, reuse_diagonal = false;
  int invalid_steps = 0;
  for (int iteration = 0; iteration < max_iterations; ++iteration) {
    if (accepted && ProjectedGradientNorm(manifold, x, gradient) <= kGradientTolerance) return;
    if (region.radius <= kMinRadius) return;
    accepted = false;
    const Matrix6 scaled_hessian = scaling.asDiagonal() * hessian * scaling.asDiagonal();
    const Vector6 scaled_gradient = scaling.cwiseProduct(gradient);
    if (!reuse_diagonal) {
      diagonal = scaled_hessian.diagonal().cwiseMax(kMinDiagonal).cwiseMin(kMaxDiagonal);
    }
    reuse_diagonal = true;
    Matrix6 lhs = scaled_hessian;
    lhs.diagonal() += (diagonal / region.radius).cwiseSqrt().cwiseAbs2();
    const Eigen::LLT<Matrix6> cholesky(lhs);
    const Vector6 step = -cholesky.solve(scaled_gradient);
    const double model_decrease =
        -step.dot(scaled_gradient) - 0.5 * step.dot(scaled_hessian * step);
    if (cholesky.info() != Eigen::Success || !step.allFinite() || !(model_decrease > 0.0)) {
      if (++invalid_steps >= kMaxConsecutiveInvalidSteps) return;
      region.Reject();
      continue;
    }
    invalid_steps = 0;
    const Vector6 delta = step.cwiseProduct(scaling);
    Vector7 candidate;
    manifold.Plus(x.data(), delta.data(), candidate.data());
    double candidate_cost = 0.0;
    if (!cost.Evaluate(candidate.data(), &candidate_cost)) {
      candidate_cost = std::numeric_limits<double>::max();
    }
    if ((x - candidate).norm() <= kParameterTolerance * (x_norm + kParameterTolerance)) return;
    if (std::abs(x_cost - candidate_cost) <= kFunctionTolerance * x_cost) return;
    const double quality = (x_cost - candidate_cost) / model_decrease;
    if (!(quality > kMinRelativeDecrease)) {
      region.Reject();
      continue;
    }
    x = candidate;
    x_norm = x.norm();
    if (!cost.Evaluate(x.data(), &x_cost, &hessian, &gradient)) return;
    region.Accept(quality);
    reuse_diagonal = false;
    accepted = true;
    Eigen::Map<Vector7> out(x_inout);
    out = x;
  }
}

}  // namespace stillmap::internal
