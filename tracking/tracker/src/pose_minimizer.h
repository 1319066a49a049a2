// Levenberg-Marquardt over one camera pose, step for step as Ceres 2.1's trust-region solver
// does it with its default options (see pose_minimizer.cpp), without Ceres' per-solve set-up.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "stillmap/tracking/rgbd_residual.h"

namespace stillmap::internal {

// The Huber-robustified RGB-D cost of a pose over the observations flagged active.
class PoseCost {
 public:
  // huber_scales[i]: the Huber loss's scale of observation i (sqrt of its chi-square threshold).
  PoseCost(const std::vector<Eigen::Vector3d>& points_in_world,
           const std::vector<RgbdObservation>& observations, std::vector<double> huber_scales);

  void set_active(std::vector<bool> active) { active_ = std::move(active); }

  // 1/2 sum rho(|r_i|^2) at the pose `x` (PoseManifold's 7 parameters); false when an active
  // point lies behind the camera. With `hessian` and `gradient`: J'J and J'r of the residuals and
  // Jacobians scaled by sqrt(rho'), as Ceres' corrector does for a loss without curvature.
  bool Evaluate(const double* x, double* cost, Eigen::Matrix<double, 6, 6>* hessian = nullptr,
                Eigen::Matrix<double, 6, 1>* gradient = nullptr) const;

 private:
  const std::vector<Eigen::Vector3d>& points_;
  const std::vector<RgbdObservation>& observations_;
  std::vector<double> huber_;
  std::vector<bool> active_;
};

// Minimizes `cost` from the pose `x` (7 parameters, updated in place) with at most
// `max_iterations` trust-region steps; `x` is left at the last accepted step.
void MinimizePose(const PoseCost& cost, int max_iterations, double* x);

}  // namespace stillmap::internal
