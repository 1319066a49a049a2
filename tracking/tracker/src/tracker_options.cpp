// The checks of the tracker's options, part by part (tracker_options.h, loop_closure.h), then
// the solvers' and those across parts.
#include <fmt/format.h>

#include "stillmap/io/error.h"
#include "stillmap/io/option_names.h"
#include "stillmap/tracking/tracker.h"

namespace stillmap {
namespace {

// Throws the message, its {} the keys given, when `ok` is false.
template <typename... Keys>
void Require(bool ok, fmt::format_string<Keys...> message, Keys&&... keys) {
  if (!ok) throw InputError(fmt::format(message, std::forward<Keys>(keys)...));
}

}  // namespace

void MatchingOptions::Validate() const {
  const OptionKeys key(*this);
  Require(search_radius_px > 0.0 && wide_search_radius_px >= search_radius_px &&
              refine_search_radius_px > 0.0,
          "{} and {} must be positive, "
          "{} at most {}",
          key(search_radius_px), key(refine_search_radius_px), key(search_radius_px),
          key(wide_search_radius_px));
  // The projection search visits the feature-grid cells the radius covers: bounded work.
  Require(wide_search_radius_px <= 1000.0 && refine_search_radius_px <= 1000.0,
          "{} and {} must be at most "
          "1000",
          key(wide_search_radius_px), key(refine_search_radius_px));
  Require(max_descriptor_distance > 0 && max_descriptor_distance <= 256, "{} must lie in 1..256",
          key(max_descriptor_distance));
  Require(match_ratio > 0.0f && match_ratio <= 1.0f, "{} must lie in (0, 1]", key(match_ratio));
  Require(min_matches >= 6, "{} must be at least 6", key(min_matches));
  Require(sigma_px > 0.0 && sigma_inverse_depth > 0.0, "{} and {} must be positive", key(sigma_px),
          key(sigma_inverse_depth));
  Require(depth_calibration_interval > 0, "{} must be a positive number of keyframes",
          key(depth_calibration_interval));
  const DepthCorrectionFitOptions& fit = depth_calibration;
  Require(fit.min_pairs > 0 && fit.max_residual_m > 0.0 && fit.max_delta > 0.0,
          "{}, {} and "
          "{} must be positive",
          key(depth_calibration.min_pairs), key(depth_calibration.max_residual_m),
          key(depth_calibration.max_delta));
  Require(fit.coefficient_sigma > 0.0 && fit.residual_sigma_m > 0.0,
          "{} and "
          "{} must be positive",
          key(depth_calibration.coefficient_sigma), key(depth_calibration.residual_sigma_m));
  Require(fit.min_spread_reduction >= 0.0 && fit.min_spread_reduction_m >= 0.0,
          "{} and "
          "{} must not be negative",
          key(depth_calibration.min_spread_reduction),
          key(depth_calibration.min_spread_reduction_m));
  Require(fit.joint_min_keyframes >= 2 && fit.joint_min_significance >= 0.0 &&
              fit.joint_max_weakest_sd > 0.0,
          "{} must be at least 2, "
          "{} not negative and "
          "{} positive",
          key(depth_calibration.joint_min_keyframes), key(depth_calibration.joint_min_significance),
          key(depth_calibration.joint_max_weakest_sd));
  Require(far_depth > 0.0 && far_depth_power >= 0.0, "{} must be positive and {} not negative",
          key(far_depth), key(far_depth_power));
  Require(min_landmark_depth > 0.0 && max_landmark_depth > min_landmark_depth,
          "{} must exceed {} (> 0)", key(max_landmark_depth), key(min_landmark_depth));
}

void LocalMapOptions::Validate() const {
  const OptionKeys key(*this);
  Require(keyframe_ratio > 0.0 && keyframe_ratio <= 1.0, "{} must lie in (0, 1]",
          key(keyframe_ratio));
  Require(max_keyframe_interval >= 1 && min_keyframe_interval >= 1 &&
              min_keyframe_interval <= max_keyframe_interval,
          "{} must lie in 1..{}", key(min_keyframe_interval), key(max_keyframe_interval));
  Require(min_keyframe_inliers >= 0 && close_tracked_max >= 0 && close_untracked_min >= 0,
          "{}, {} and "
          "{} must not be negative",
          key(min_keyframe_inliers), key(close_tracked_max), key(close_untracked_min));
  Require(cull_found_ratio >= 0.0 && cull_found_ratio <= 1.0 && cull_min_visible >= 1 &&
              cull_single_view_age >= 1 && cull_recent_age >= cull_single_view_age,
          "{} must lie in [0, 1], {} and "
          "{} be at least 1, {} at least "
          "{}",
          key(cull_found_ratio), key(cull_min_visible), key(cull_single_view_age),
          key(cull_recent_age), key(cull_single_view_age));
  Require(local_window >= 2 && local_map_keyframes >= 1, "{} must be at least 2 and {} at least 1",
          key(local_window), key(local_map_keyframes));
  Require(bundle_adjustment_handover_frames >= 0 && bundle_adjustment_handover_frames <= 1000,
          "{} must be 0..1000", key(bundle_adjustment_handover_frames));
  Require(weak_tracking_inliers >= 0, "{} must not be negative", key(weak_tracking_inliers));
  Require(close_depth > 0.0, "{} must be positive", key(close_depth));
  Require(redundant_radius_m >= 0.0 && redundant_axis_angle_deg >= 0.0 &&
              redundant_axis_angle_deg <= 180.0,
          "{} must not be negative and {} "
          "lie in 0..180",
          key(redundant_radius_m), key(redundant_axis_angle_deg));
  Require(redundant_keyframe_share > 0.0 && redundant_keyframe_share <= 1.0 &&
              redundant_view_angle_deg >= 0.0 && redundant_view_angle_deg <= 180.0 &&
              redundant_scale_ratio >= 1.0,
          "{} must lie in (0, 1], "
          "{} in 0..180 and {} be at "
          "least 1",
          key(redundant_keyframe_share), key(redundant_view_angle_deg), key(redundant_scale_ratio));
  Require(redundant_retire_keyframes >= local_window && redundant_retire_keyframes <= 10000,
          "{} must be {}..10000", key(redundant_retire_keyframes), key(local_window));
  Require(landmark_merge_distance_m >= 0.0, "{} must not be negative",
          key(landmark_merge_distance_m));
}

void RgbdOdometryOptions::Validate() const {
  const OptionKeys key(*this);
  Require(cell_px >= 1 && cell_px <= 64 && iterations >= 1 && keyframe_interval >= 1,
          "{} must be 1..64, {} and {} at least 1", key(cell_px), key(iterations),
          key(keyframe_interval));
  Require(min_pair_distance_m > 0.0 && max_pair_distance_m >= min_pair_distance_m,
          "{} must be positive and at most {}", key(min_pair_distance_m), key(max_pair_distance_m));
  Require(max_normal_angle_deg > 0.0 && max_normal_angle_deg <= 90.0, "{} must lie in (0, 90]",
          key(max_normal_angle_deg));
  Require(max_depth_m > 0.0 && sigma_depth_m > 0.0 && sigma_intensity > 0.0 && max_rmse_m > 0.0 &&
              max_weakest_sigma_m > 0.0,
          "{}, {}, {}, {} and {} must be positive", key(max_depth_m), key(sigma_depth_m),
          key(sigma_intensity), key(max_rmse_m), key(max_weakest_sigma_m));
  Require(min_intensity_correlation >= -1.0 && min_intensity_correlation <= 1.0,
          "{} must lie in [-1, 1]", key(min_intensity_correlation));
  Require(
      min_paired_share >= 0.0 && min_paired_share <= 1.0 && min_gradient >= 0.0 && max_gap_s >= 0.0,
      "{} must lie in [0, 1], {} and {} not be negative", key(min_paired_share), key(min_gradient),
      key(max_gap_s));
  Require(check_below_inliers >= 0 && check_max_difference_m >= 0.0 &&
              check_max_difference_deg >= 0.0 && check_max_gap_s >= 0.0 && check_min_landmarks >= 0,
          "{}, {}, {}, {} and {} must not be negative", key(check_below_inliers),
          key(check_max_difference_m), key(check_max_difference_deg), key(check_max_gap_s),
          key(check_min_landmarks));
}

void RelocalizationOptions::Validate() const {
  const OptionKeys key(*this);
  Require(min_tracked >= 6 && min_relocalized >= min_tracked,
          "{} must be at least 6 and at most {}", key(min_tracked), key(min_relocalized));
  Require(relocalization_keyframes >= 1, "{} must be at least 1", key(relocalization_keyframes));
  Require(new_map_after_lost >= 1, "{} must be at least 1", key(new_map_after_lost));
  Require(min_initial_points >= 20 && new_map_min_points >= 20, "{} and {} must be at least 20",
          key(min_initial_points), key(new_map_min_points));
  Require(
      min_static_depth_share >= 0.0 && min_static_depth_share <= 1.0 && max_predicted_frames >= 0,
      "{} must lie in [0, 1] and {} "
      "not be negative",
      key(min_static_depth_share), key(max_predicted_frames));
  // Across the parts: a loop is verified with at least a tracked frame's inliers.
  Require(relocalization_max_distance_m > 0.0 && relocalization_max_speed_mps >= 0.0,
          "{} must be positive and "
          "{} not negative",
          key(relocalization_max_distance_m), key(relocalization_max_speed_mps));
  Require(motion_model_horizon_s >= 0.0 && motion_model_max_distance_m > 0.0,
          "{} must not be negative and {} must be positive", key(motion_model_horizon_s),
          key(motion_model_max_distance_m));
}

void LoopClosureOptions::Validate() const {
  const OptionKeys key(*this);
  place.Validate();
  Require(place_candidates >= 1 && place_min_votes >= 1, "{} and {} must be at least 1",
          key(place_candidates), key(place_min_votes));
  Require(loop_consistency >= 1 && loop_min_separation >= 1, "{} and {} must be at least 1",
          key(loop_consistency), key(loop_min_separation));
  Require(loop_max_drift_m >= 0.0 && loop_max_drift_share >= 0.0 && loop_max_drift_deg >= 0.0 &&
              loop_max_drift_deg_per_m >= 0.0,
          "{}, {}, {} and {} must not be negative", key(loop_max_drift_m),
          key(loop_max_drift_share), key(loop_max_drift_deg), key(loop_max_drift_deg_per_m));
  Require(pose_graph_min_shared >= 1 && pose_graph.iterations >= 1 &&
              pose_graph.iterations <= 1000 && pose_graph.translation_sigma_m > 0.0 &&
              pose_graph.rotation_sigma_rad > 0.0,
          "{} must be at least 1, {} "
          "1..1000 and the pose graph's sigmas positive",
          key(pose_graph_min_shared), key(pose_graph.iterations));
  Require(pose_graph_full_weight_inliers >= 1 && pose_graph_min_weight > 0.0 &&
              pose_graph_min_weight <= 1.0,
          "{} must be at least 1 and {} in (0, 1]", key(pose_graph_full_weight_inliers),
          key(pose_graph_min_weight));
  Require(loop_handover_frames >= 0 && loop_handover_frames <= 1000 &&
              global_bundle_adjustment_handover_frames >= 0 &&
              global_bundle_adjustment_handover_frames <= 1000,
          "{} and "
          "{} must be 0..1000",
          key(loop_handover_frames), key(global_bundle_adjustment_handover_frames));
}

void FloorNormalOptions::Validate() const {
  const OptionKeys key(*this);
  Require(stride_px >= 1 && stride_px <= 64, "{} must be 1..64", key(stride_px));
  Require(max_depth_m > 0.0 && layer_m > 0.0 && inlier_m > 0.0, "{}, {} and {} must be positive",
          key(max_depth_m), key(layer_m), key(inlier_m));
  Require(min_layer_share >= 0.0 && min_layer_share <= 1.0, "{} must lie in [0, 1]",
          key(min_layer_share));
  Require(min_points >= 3, "{} must be at least 3", key(min_points));
  Require(max_angle_deg > 0.0 && max_angle_deg <= 90.0, "{} must lie in (0, 90]",
          key(max_angle_deg));
  Require(min_keyframes >= 1 && max_keyframes >= min_keyframes,
          "{} must be at least 1 and {} "
          "at least {}",
          key(min_keyframes), key(max_keyframes), key(min_keyframes));
}

void TrackerOptions::Validate() const {
  features.Validate();
  planar_floor.Validate();
  matching.Validate();
  local_map.Validate();
  const OptionKeys key(*this);
  Require(pnp.max_reprojection_error > 0.0 && pnp.refine_reprojection_error > 0.0,
          "{} and {} must "
          "be positive",
          key(pnp.max_reprojection_error), key(pnp.refine_reprojection_error));
  Require(pnp.iterations >= 1 && pnp.iterations <= 100000, "{} must be 1..100000",
          key(pnp.iterations));
  Require(pnp.confidence > 0.0 && pnp.confidence < 1.0, "{} must be in (0, 1)",
          key(pnp.confidence));
  Require(pnp.min_inliers >= 4, "{} must be at least 4", key(pnp.min_inliers));
  Require(refinement.rounds >= 1 && refinement.rounds <= 20 &&
              refinement.iterations_per_round >= 1 && refinement.iterations_per_round <= 1000,
          "{} must be 1..20 and {} "
          "1..1000",
          key(refinement.rounds), key(refinement.iterations_per_round));
  Require(refinement.chi2_without_depth > 0.0 && refinement.chi2_with_depth > 0.0,
          "{} and {} must "
          "be positive",
          key(refinement.chi2_without_depth), key(refinement.chi2_with_depth));
  Require(refinement.min_inliers >= 4, "{} must be at least 4", key(refinement.min_inliers));
  Require(bundle_adjustment.iterations_first >= 1 && bundle_adjustment.iterations_first <= 1000 &&
              bundle_adjustment.iterations_second >= 1 &&
              bundle_adjustment.iterations_second <= 1000,
          "{} and {} must be 1..1000", key(bundle_adjustment.iterations_first),
          key(bundle_adjustment.iterations_second));
  Require(bundle_adjustment.min_keyframe_observations >= 0, "{} must not be negative",
          key(bundle_adjustment.min_keyframe_observations));
  Require(bundle_adjustment.chi2_without_depth > 0.0 && bundle_adjustment.chi2_with_depth > 0.0,
          "{} and {} must be positive", key(bundle_adjustment.chi2_without_depth),
          key(bundle_adjustment.chi2_with_depth));
  Require(bundle_adjustment.dense_schur_max_poses >= 0, "{} must be 0 or more",
          key(bundle_adjustment.dense_schur_max_poses));
  relocalization.Validate();
  rgbd_odometry.Validate();
  loops.Validate();
  // Across the parts: a loop is verified with at least a tracked frame's inliers.
  Require(loops.loop_min_inliers >= relocalization.min_tracked, "{} must be at least {}",
          key(loops.loop_min_inliers), key(relocalization.min_tracked));
}

}  // namespace stillmap
