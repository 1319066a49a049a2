// Internal: the pose parameterization shared by motion-only refinement and bundle adjustment.
#pragma once

#include <ceres/manifold.h>

#include <Eigen/Geometry>

namespace stillmap::internal {

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
inline Eigen::Isometry3d PoseFromParameters(const double* pose) {
  Eigen::Isometry3d camera_from_world = Eigen::Isometry3d::Identity();
  camera_from_world.linear() = Eigen::Map<const Eigen::Quaterniond>(pose).toRotationMatrix();
  camera_from_world.translation() = Eigen::Map<const Eigen::Vector3d>(pose + 4);
  return camera_from_world;
}

// Writes camera_from_world as [qx qy qz qw tx ty tz].
inline void PoseToParameters(const Eigen::Isometry3d& camera_from_world, double* pose) {
  Eigen::Map<Eigen::Quaterniond> rotation(pose);
  Eigen::Map<Eigen::Vector3d> translation(pose + 4);
  rotation = Eigen::Quaterniond(camera_from_world.linear()).normalized();
  translation = camera_from_world.translation();
}

}  // namespace stillmap::internal
