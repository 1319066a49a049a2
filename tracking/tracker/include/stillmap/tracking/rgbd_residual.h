// The RGB-D observation residual the pose refinement minimizes, with its analytic Jacobian.
#pragma once

#include <Eigen/Geometry>

namespace stillmap {

// One observation of a 3-D point by an RGB-D camera: where it appears and, when the depth image
// has a reading there, how far it is.
struct RgbdObservation {
  Eigen::Vector2d normalized = Eigen::Vector2d::Zero();  // undistorted (x/z, y/z)
  double depth_m = 0.0;                 // 0 = no reading: the depth row of the residual is zero
  double sigma_normalized = 1.0 / 525;  // image noise, normalized units (1 px at fx = 525)
  double sigma_inverse_depth = 0.0005;  // noise of 1/depth [1/m]; Kinect depth noise is close to
                                        // uniform in disparity, i.e. in inverse depth
};

// r = [(X/Z - x) / s_n, (Y/Z - y) / s_n, (1/Z - 1/d) / s_i] with (X, Y, Z) = camera_from_world *
// point_in_world. `jacobian` (optional) is dr / d[w, v] for the left perturbation
// camera_from_world <- Exp([w, v]) camera_from_world, applied as q' = exp(w^) q + v: columns
// 0-2 rotation, 3-5 translation. Returns false (and leaves the outputs alone) when the point is
// not in front of the camera.
bool EvaluateRgbdResidual(const Eigen::Isometry3d& camera_from_world,
                          const Eigen::Vector3d& point_in_world, const RgbdObservation& observation,
                          Eigen::Vector3d* residual, Eigen::Matrix<double, 3, 6>* jacobian);

}  // namespace stillmap
