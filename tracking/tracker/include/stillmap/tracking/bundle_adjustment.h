// Bundle adjustment of keyframe poses and landmark positions with RGB-D observations (the
// residual of rgbd_residual.h), solved with Ceres. Some keyframes may be held fixed: the local
// bundle adjustment of the tracker optimizes a window of recent keyframes and the landmarks they
// see, holding the older keyframes that also see those landmarks fixed.
#pragma once

#include <Eigen/Geometry>
#include <optional>
#include <vector>

#include "stillmap/tracking/depth_correction.h"
#include "stillmap/tracking/rgbd_residual.h"

namespace stillmap {

struct BundleAdjustmentOptions {
  int iterations_first = 5;
  int iterations_second = 10;  // and after (ORB-SLAM2's local BA: 5 + 10)
  // Chi-square thresholds at 95 % for whitened residuals (2 dof without depth, 3 with).
  double chi2_without_depth = 5.991;
  double chi2_with_depth = 7.815;
  // The Schur complement leaves a system in the free poses alone. Held dense it takes (6 N)^2
  // doubles and O(N^3) per factorization for N poses: right for the local window (8), but a
  // global adjustment over a floor's long segment (hundreds of poses) then took most of the
  // build's memory and time (docs/figures.md, issue 47). Poses along a long path see few of each
  // other, so there the system is mostly empty: above this many free poses it is solved sparse
  // (SuiteSparse, as the pose graph). The same equations: the solutions agree to rounding.
  int dense_schur_max_poses = 100;
  // A keyframe with fewer observations than this (inliers, in the second round) keeps its pose:
  // so few points do not place it, and window after window they move it anywhere (floor seed 1: a
  // new map segment's second keyframe, seen by 3-7 landmarks, went 2 m off in five windows,
  // docs/figures.md). As many as a tracked pose needs (tracking.refinement_min_inliers).
  int min_keyframe_observations = 12;

  // Every field under its configuration key (io/option_fields.h).
  template <typename Self, typename Visitor>
  static void VisitFields(Self& self, Visitor& visit) {
    visit("iterations_first", self.iterations_first,
          "Levenberg-Marquardt iterations before outliers are removed (ORB-SLAM2: 5)");
    visit("iterations_second", self.iterations_second,
          "Levenberg-Marquardt iterations after outliers are removed (ORB-SLAM2: 10)");
    visit("chi2_without_depth", self.chi2_without_depth,
          "outlier threshold, whitened, 2 dof (chi-square 95 %: 5.991)");
    visit("chi2_with_depth", self.chi2_with_depth,
          "outlier threshold, whitened, 3 dof (chi-square 95 %: 7.815)");
    visit("dense_schur_max_poses", self.dense_schur_max_poses,
          "free poses up to which the reduced camera system is solved dense; sparse above");
    visit("min_keyframe_observations", self.min_keyframe_observations,
          "a keyframe with fewer observations (inliers) keeps its pose in the adjustment");
  }
};

struct BundleAdjustmentKeyframe {
  Eigen::Isometry3d camera_from_world = Eigen::Isometry3d::Identity();
  bool fixed = false;
};

struct BundleAdjustmentObservation {
  int keyframe = 0;  // index into BundleAdjustmentProblem::keyframes
  int landmark = 0;  // index into BundleAdjustmentProblem::landmarks
  RgbdObservation observation;
};

struct BundleAdjustmentProblem {
  std::vector<BundleAdjustmentKeyframe> keyframes;
  std::vector<Eigen::Vector3d> landmarks;  // world frame
  std::vector<BundleAdjustmentObservation> observations;
  // Joint depth self-calibration (Teichman et al., RSS 2013): when set, the observations' depths
  // are raw readings, and the depth correction (depth_correction.h) is estimated with the poses
  // and points, starting from this one, under a zero-mean prior of depth_correction_sigma on each
  // coefficient (keeps directions the window cannot see at zero).
  std::optional<DepthCorrection> depth_correction;
  double depth_correction_sigma = 0.1;
};

struct BundleAdjustmentResult {
  std::vector<Eigen::Isometry3d> camera_from_world;  // per keyframe (fixed ones unchanged)
  std::vector<Eigen::Vector3d> landmarks;
  std::vector<bool> outlier;  // per observation: failed the chi-square test at the end
  std::optional<DepthCorrection> depth_correction;  // estimated, when the problem asked for it
  // Its standard deviation along the direction the observations pin down least (landmark depths
  // marginalized, poses not), and p' I p for the estimate p and information I (chi-square, 5 dof,
  // when the sensor has no error).
  double depth_correction_weakest_sd = 0.0;
  double depth_correction_significance = 0.0;
  double initial_cost = 0.0;  // Ceres cost (robustified) before and after
  double final_cost = 0.0;
  int iterations = 0;
};

// Solves, removes the observations that fail the chi-square test, and solves again. Landmarks
// and keyframes without observations are returned unchanged. With no fixed keyframe, the gauge
// is free: callers hold at least one keyframe fixed.
BundleAdjustmentResult SolveBundleAdjustment(const BundleAdjustmentProblem& problem,
                                             const BundleAdjustmentOptions& options = {});

}  // namespace stillmap
