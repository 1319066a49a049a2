// Motion-only refinement of a camera pose from RGB-D observations of known 3-D points.
#pragma once

#include <Eigen/Geometry>
#include <vector>

#include "stillmap/tracking/pose_estimation.h"
#include "stillmap/tracking/rgbd_residual.h"

namespace stillmap {

struct RefinementOptions {
  int rounds = 4;  // solve, reject outliers, solve again (ORB-SLAM2: 4 rounds)
  int iterations_per_round = 10;
  // Chi-square thresholds at 95 % for whitened residuals: 2 dof (no depth), 3 dof (with depth).
  double chi2_without_depth = 5.991;
  double chi2_with_depth = 7.815;
  int min_inliers = 12;

  // Every field under its configuration key (io/option_fields.h).
  template <typename Self, typename Visitor>
  static void VisitFields(Self& self, Visitor& visit) {
    visit("rounds", self.rounds, "solve / reject outliers rounds (ORB-SLAM2: 4)");
    visit("iterations_per_round", self.iterations_per_round,
          "Levenberg-Marquardt iterations per round");
    visit("chi2_without_depth", self.chi2_without_depth,
          "outlier threshold, whitened, 2 dof (chi-square 95 %: 5.991)");
    visit("chi2_with_depth", self.chi2_with_depth,
          "outlier threshold, whitened, 3 dof (chi-square 95 %: 7.815)");
    visit("min_inliers", self.min_inliers, "fewer inliers: the refined pose is not trusted");
  }
};

// Refines camera_from_world starting from `initial` by minimizing the Huber-robustified RGB-D
// residuals (EvaluateRgbdResidual) over the pose only; after each round, observations whose
// squared whitened residual exceeds the chi-square threshold are left out of the next one.
PoseResult RefinePose(const Eigen::Isometry3d& initial,
                      const std::vector<Eigen::Vector3d>& points_in_world,
                      const std::vector<RgbdObservation>& observations,
                      const RefinementOptions& options = {});

}  // namespace stillmap
