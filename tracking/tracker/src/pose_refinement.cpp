#include "stillmap/tracking/pose_refinement.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include "pose_manifold.h"
#include "pose_minimizer.h"

namespace stillmap {
namespace {

using internal::PoseFromParameters;
using internal::PoseToParameters;

// The chi-square threshold of an observation: 3 dof with a depth reading, 2 without.
double ChiSquareThreshold(const RgbdObservation& observation, const RefinementOptions& options) {
  return observation.depth_m > 0.0 ? options.chi2_with_depth : options.chi2_without_depth;
}

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
  PoseToParameters(initial, pose);
  std::vector<double> huber_scales;
  huber_scales.reserve(n);
  for (const RgbdObservation& observation : observations) {
    huber_scales.push_back(std::sqrt(ChiSquareThreshold(observation, options)));
  }
  // One cost for all rounds: outliers are switched off rather than removed, and may come back
  // after a later round.
  internal::PoseCost cost(points_in_world, observations, std::move(huber_scales));
  std::vector<bool> inlier(n, true);
  for (int round = 0; round < options.rounds; ++round) {
    const auto used = std::count(inlier.begin(), inlier.end(), true);
    if (used < options.min_inliers) break;
    cost.set_active(inlier);
    internal::MinimizePose(cost, options.iterations_per_round, pose);
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
