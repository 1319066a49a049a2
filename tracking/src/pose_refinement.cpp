#include "stillmap/tracking/pose_refinement.h"

#include <ceres/ceres.h>

#include <cmath>
#include <utility>

namespace stillmap {
namespace {

// Pose parameters [qx qy qz qw tx ty tz] (camera_from_world). The tangent step [w v] is the
// left perturbation of EvaluateRgbdResidual: q' = exp(w^) (R p + t) + v. The cost functions give
// their Jacobian in that tangent space directly (in the first six ambient columns), so
// PlusJacobian is the 7x6 matrix [I; 0].
class PoseManifold : public ceres::Manifold {
 public:
  int AmbientSize() const override { return 7; }
  int TangentSize() const override { return 6; }

  bool Plus(const double* x, const double* delta, double* x_plus_delta) const override {
    const Eigen::Map<const Eigen::Quaterniond> q(x);
    const Eigen::Map<const Eigen::Vector3d> t(x + 4);
    const Eigen::Map<const Eigen::Vector3d> w(delta), v(delta + 3);
    const double angle = w.norm();
    const Eigen::Quaterniond dq =
        angle > 1e-12 ? Eigen::Quaterniond(Eigen::AngleAxisd(angle, w / angle))
                      : Eigen::Quaterniond(1.0, 0.5 * w.x(), 0.5 * w.y(), 0.5 * w.z()).normalized();
    Eigen::Map<Eigen::Quaterniond> q_out(x_plus_delta);
    Eigen::Map<Eigen::Vector3d> t_out(x_plus_delta + 4);
    q_out = (dq * q).normalized();
    t_out = dq * t + v;
    return true;
  }
  bool PlusJacobian(const double* /*x*/, double* jacobian) const override {
    Eigen::Map<Eigen::Matrix<double, 7, 6, Eigen::RowMajor>> j(jacobian);
    j.setZero();
    j.topRows<6>().setIdentity();
    return true;
  }
  bool Minus(const double* y, const double* x, double* y_minus_x) const override {
    const Eigen::Map<const Eigen::Quaterniond> qx(x), qy(y);
    const Eigen::Map<const Eigen::Vector3d> tx(x + 4), ty(y + 4);
    const Eigen::Quaterniond dq = qy * qx.conjugate();
    const Eigen::AngleAxisd axis_angle(dq);
    Eigen::Map<Eigen::Vector3d> w_out(y_minus_x), v_out(y_minus_x + 3);
    w_out = axis_angle.angle() * axis_angle.axis();
    v_out = ty - dq * tx;
    return true;
  }
  bool MinusJacobian(const double* /*x*/, double* jacobian) const override {
    Eigen::Map<Eigen::Matrix<double, 6, 7, Eigen::RowMajor>> j(jacobian);
    j.setZero();
    j.leftCols<6>().setIdentity();
    return true;
  }
};

// camera_from_world from the parameters [qx qy qz qw tx ty tz].
Eigen::Isometry3d PoseFromParameters(const double* pose) {
  Eigen::Isometry3d camera_from_world = Eigen::Isometry3d::Identity();
  camera_from_world.linear() = Eigen::Map<const Eigen::Quaterniond>(pose).toRotationMatrix();
  camera_from_world.translation() = Eigen::Map<const Eigen::Vector3d>(pose + 4);
  return camera_from_world;
}

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
  Eigen::Map<Eigen::Quaterniond> pose_rotation(pose);
  Eigen::Map<Eigen::Vector3d> pose_translation(pose + 4);
  pose_rotation = Eigen::Quaterniond(initial.linear()).normalized();
  pose_translation = initial.translation();
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
