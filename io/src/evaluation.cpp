#include "stillmap/io/evaluation.h"

#include <fmt/format.h>

#include <Eigen/Geometry>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <numeric>

#include "stillmap/io/error.h"
#include "stillmap/io/file_list.h"

namespace stillmap {

ErrorStatistics ComputeStatistics(std::vector<double> errors) {
  ErrorStatistics stats;
  stats.count = errors.size();
  if (errors.empty()) return stats;
  const double n = static_cast<double>(errors.size());
  double sum = 0.0;
  double sum_squares = 0.0;
  for (double e : errors) {
    sum += e;
    sum_squares += e * e;
  }
  stats.mean = sum / n;
  stats.rmse = std::sqrt(sum_squares / n);
  double variance = 0.0;
  for (double e : errors) variance += (e - stats.mean) * (e - stats.mean);
  stats.std_dev = std::sqrt(variance / n);
  std::sort(errors.begin(), errors.end());
  stats.min = errors.front();
  stats.max = errors.back();
  const size_t mid = errors.size() / 2;
  stats.median = errors.size() % 2 == 1 ? errors[mid] : 0.5 * (errors[mid - 1] + errors[mid]);
  return stats;
}

AteResult ComputeAte(const Trajectory& groundtruth, const Trajectory& estimate,
                     const AteOptions& options) {
  const std::vector<std::pair<size_t, size_t>> matches =
      AssociateTimestamps(estimate.Times(), groundtruth.Times(), options.max_time_difference);
  if (matches.size() < 3) {
    throw InputError(fmt::format(
        "ATE: only {} estimate pose(s) associated with a ground-truth pose within {} s (3 needed); "
        "are the files from the same sequence (or raise --max-diff)?",
        matches.size(), options.max_time_difference));
  }
  Eigen::Matrix3Xd estimate_xyz(3, matches.size());
  Eigen::Matrix3Xd groundtruth_xyz(3, matches.size());
  AteResult result;
  for (size_t k = 0; k < matches.size(); ++k) {
    estimate_xyz.col(k) = estimate.poses()[matches[k].first].world_from_camera.translation();
    groundtruth_xyz.col(k) = groundtruth.poses()[matches[k].second].world_from_camera.translation();
    result.times.push_back(estimate.poses()[matches[k].first].time);
  }
  result.groundtruth_from_estimate.matrix() = Eigen::umeyama(estimate_xyz, groundtruth_xyz, false);
  for (size_t k = 0; k < matches.size(); ++k) {
    const Eigen::Vector3d aligned = result.groundtruth_from_estimate * estimate_xyz.col(k);
    result.aligned_positions.push_back(aligned);
    result.groundtruth_positions.push_back(groundtruth_xyz.col(k));
    result.errors.push_back((aligned - groundtruth_xyz.col(k)).norm());
  }
  result.translation = ComputeStatistics(result.errors);
  return result;
}

RpeResult ComputeRpe(const Trajectory& groundtruth, const Trajectory& estimate,
                     const RpeOptions& options) {
  const std::vector<double> gt_times = groundtruth.Times();
  const std::vector<double> est_times = estimate.Times();
  if (gt_times.size() < 2 || est_times.size() < 2) {
    throw InputError("RPE: both trajectories need at least two poses");
  }
  std::vector<double> intervals(gt_times.size() - 1);
  for (size_t i = 1; i < gt_times.size(); ++i) intervals[i - 1] = gt_times[i] - gt_times[i - 1];
  const double max_gt_difference = 2.0 * ComputeStatistics(intervals).median;

  std::vector<double> translation_errors;
  std::vector<double> rotation_errors_deg;
  for (size_t i = 0; i < est_times.size(); ++i) {
    const size_t j = FindClosestIndex(est_times, est_times[i] + options.delta);
    // evaluate_rpe.py's pair rule: a pair ending on the last estimate pose is dropped (near the
    // end every t_i + delta falls on it, and those pairs are shorter than delta).
    if (j == est_times.size() - 1) continue;
    const size_t gi = FindClosestIndex(gt_times, est_times[i]);
    const size_t gj = FindClosestIndex(gt_times, est_times[j]);
    if (std::abs(gt_times[gi] - est_times[i]) > max_gt_difference ||
        std::abs(gt_times[gj] - est_times[j]) > max_gt_difference) {
      continue;
    }
    // evaluate_rpe.py: ominus(a, b) = a^-1 b; error = ominus(ominus(E_j, E_i), ominus(G_j, G_i)).
    const Eigen::Isometry3d estimate_motion =
        estimate.poses()[j].world_from_camera.inverse() * estimate.poses()[i].world_from_camera;
    const Eigen::Isometry3d groundtruth_motion =
        groundtruth.poses()[gj].world_from_camera.inverse() *
        groundtruth.poses()[gi].world_from_camera;
    const Eigen::Isometry3d error = estimate_motion.inverse() * groundtruth_motion;
    translation_errors.push_back(error.translation().norm());
    const double cos_angle = std::clamp((error.linear().trace() - 1.0) / 2.0, -1.0, 1.0);
    rotation_errors_deg.push_back(std::acos(cos_angle) * 180.0 / M_PI);
  }
  if (translation_errors.empty()) {
    const double span = est_times.back() - est_times.front();
    if (span <= options.delta) {
      throw InputError(fmt::format(
          "RPE: the estimate spans {:.3f} s, not more than the pair delta of {} s, so every pair "
          "would end on its last pose (evaluate_rpe.py drops those); lower the delta",
          span, options.delta));
    }
    throw InputError("RPE: no estimate pose has a ground-truth pose close enough in time");
  }
  RpeResult result;
  result.translation = ComputeStatistics(translation_errors);
  result.rotation = ComputeStatistics(rotation_errors_deg);
  return result;
}

Eigen::Isometry3d FitPoses(const std::vector<Eigen::Isometry3d>& groundtruth,
                           const std::vector<Eigen::Isometry3d>& estimate) {
  Eigen::Matrix3d rotations = Eigen::Matrix3d::Zero();
  for (size_t i = 0; i < estimate.size(); ++i) {
    rotations += groundtruth[i].linear() * estimate[i].linear().transpose();
  }
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(rotations, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d sign = Eigen::Matrix3d::Identity();
  sign(2, 2) = (svd.matrixU() * svd.matrixV().transpose()).determinant() < 0.0 ? -1.0 : 1.0;
  Eigen::Isometry3d fit = Eigen::Isometry3d::Identity();
  fit.linear() = svd.matrixU() * sign * svd.matrixV().transpose();
  Eigen::Vector3d offset = Eigen::Vector3d::Zero();
  for (size_t i = 0; i < estimate.size(); ++i) {
    offset += groundtruth[i].translation() - fit.linear() * estimate[i].translation();
  }
  fit.translation() = offset / static_cast<double>(estimate.size());
  return fit;
}

}  // namespace stillmap
