// Trajectory accuracy exactly as the TUM RGB-D benchmark defines it (evaluate_ate.py and
// evaluate_rpe.py): what every ATE and RPE figure of stillmap means.
#pragma once

#include <Eigen/Geometry>
#include <string>
#include <vector>

#include "stillmap/io/option_fields.h"
#include "stillmap/io/trajectory.h"

namespace stillmap {

// Summary statistics of a list of errors.
struct ErrorStatistics {
  size_t count = 0;
  double rmse = 0.0;
  double mean = 0.0;
  double median = 0.0;
  double std_dev = 0.0;  // population standard deviation, as numpy.std
  double min = 0.0;
  double max = 0.0;
};

// Statistics of `errors`; all zero when empty.
ErrorStatistics ComputeStatistics(std::vector<double> errors);

struct AteOptions {
  double max_time_difference = 0.02;

  // Every field under its configuration key (io/option_fields.h).
  template <typename Self, typename Visitor>
  static void VisitFields(Self& self, Visitor& visit) {
    visit("max_time_difference", self.max_time_difference,
          "ATE association window [s] (evaluate_ate.py --max_difference)");
  }
};

// Absolute trajectory error: the estimate is associated to the ground truth by timestamp, aligned
// to it by the rigid transform (no scale) minimizing the squared position differences (Horn's
// closed form; computed with Eigen's Umeyama, which yields the same optimum), and the remaining
// position differences are summarized.
struct AteResult {
  ErrorStatistics translation;                                                  // [m]
  Eigen::Isometry3d groundtruth_from_estimate = Eigen::Isometry3d::Identity();  // the alignment
  std::vector<double> times;                           // estimate times of the associated pairs [s]
  std::vector<Eigen::Vector3d> groundtruth_positions;  // associated ground-truth positions
  std::vector<Eigen::Vector3d> aligned_positions;      // associated estimates after alignment
  std::vector<double> errors;                          // per pair [m]
};

// Throws InputError when fewer than 3 poses associate (no alignment is defined).
AteResult ComputeAte(const Trajectory& groundtruth, const Trajectory& estimate,
                     const AteOptions& options = {});

// The rigid transform T that best carries each estimate pose onto its ground-truth pose (pairs at
// the same index): its rotation is the one nearest the sum of R_truth R_estimate^T (the chordal
// mean of the rotation differences, fixed by every pose, unlike the ATE's alignment from
// positions along a short or straight path), its translation the mean of p_truth - R p_estimate.
// Places a map in the truth's frame for its quality figures. `estimate` and `groundtruth` hold
// at least one pose each, as many.
Eigen::Isometry3d FitPoses(const std::vector<Eigen::Isometry3d>& groundtruth,
                           const std::vector<Eigen::Isometry3d>& estimate);

struct RpeOptions {
  double delta = 1.0;  // fixed time delta between the poses of a pair [s] (--fixed_delta --delta 1)

  // Every field under its configuration key (io/option_fields.h).
  template <typename Self, typename Visitor>
  static void VisitFields(Self& self, Visitor& visit) {
    visit("delta", self.delta, "RPE pose-pair time delta [s] (evaluate_rpe.py --delta)");
  }
};

// Relative pose error over pairs of estimate poses `delta` seconds apart, as evaluate_rpe.py
// with --fixed_delta and delta unit 's': for every estimate pose i, j is the estimate nearest to
// t_i + delta, and pairs whose j is the last estimate pose are dropped (the script's rule);
// ground-truth poses are the nearest to t_i and t_j and must lie within twice the median
// ground-truth sampling interval. Error = (E_j^-1 E_i)^-1 (G_j^-1 G_i). Unlike the script,
// all pairs are used (no random subsampling beyond 10000 pairs), so the figure is deterministic.
struct RpeResult {
  ErrorStatistics translation;  // per pair [m], i.e. [m/s] for delta = 1 s
  ErrorStatistics rotation;     // per pair [deg], i.e. [deg/s] for delta = 1 s
};

// Throws InputError when no pair can be formed.
RpeResult ComputeRpe(const Trajectory& groundtruth, const Trajectory& estimate,
                     const RpeOptions& options = {});

}  // namespace stillmap
