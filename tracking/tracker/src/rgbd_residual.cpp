#include "stillmap/tracking/rgbd_residual.h"

namespace stillmap {

bool EvaluateRgbdResidual(const Eigen::Isometry3d& camera_from_world,
                          const Eigen::Vector3d& point_in_world, const RgbdObservation& observation,
                          Eigen::Vector3d* residual, Eigen::Matrix<double, 3, 6>* jacobian) {
  const Eigen::Vector3d q = camera_from_world * point_in_world;
  if (!(q.z() > 1e-6)) return false;
  const double inverse_z = 1.0 / q.z();
  const double has_depth = observation.depth_m > 0.0 ? 1.0 : 0.0;
  const double w_n = 1.0 / observation.sigma_normalized;
  const double w_d = has_depth / observation.sigma_inverse_depth;
  (*residual)[0] = w_n * (q.x() * inverse_z - observation.normalized.x());
  (*residual)[1] = w_n * (q.y() * inverse_z - observation.normalized.y());
  (*residual)[2] = has_depth > 0.0 ? w_d * (inverse_z - 1.0 / observation.depth_m) : 0.0;
  if (jacobian != nullptr) {
    // dr/dq for q = (X, Y, Z).
    Eigen::Matrix3d dr_dq;
    dr_dq << w_n * inverse_z, 0.0, -w_n * q.x() * inverse_z * inverse_z,  //
        0.0, w_n * inverse_z, -w_n * q.y() * inverse_z * inverse_z,       //
        0.0, 0.0, -w_d * inverse_z * inverse_z;
    // dq/dw = -[q]x (left rotation perturbation), dq/dv = I.
    Eigen::Matrix3d skew;
    skew << 0.0, -q.z(), q.y(), q.z(), 0.0, -q.x(), -q.y(), q.x(), 0.0;
    jacobian->leftCols<3>() = -dr_dq * skew;
    jacobian->rightCols<3>() = dr_dq;
  }
  return true;
}

}  // namespace stillmap
