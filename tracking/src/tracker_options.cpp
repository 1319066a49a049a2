// TrackerOptions::Validate, in three parts: matching and depth, keyframes and the solvers,
// relocalization, redundancy and loops.
#include "stillmap/io/error.h"
#include "stillmap/tracking/tracker.h"

namespace stillmap {
namespace {

void Require(bool ok, const char* message) {
  if (!ok) throw InputError(message);
}

}  // namespace

void TrackerOptions::ValidateMatching() const {
  Require(search_radius_px > 0.0 && wide_search_radius_px >= search_radius_px &&
              refine_search_radius_px > 0.0,
          "tracking.search_radius_px and tracking.refine_search_radius_px must be positive, "
          "tracking.search_radius_px at most tracking.wide_search_radius_px");
  // The projection search visits the feature-grid cells the radius covers: bounded work.
  Require(wide_search_radius_px <= 1000.0 && refine_search_radius_px <= 1000.0,
          "tracking.wide_search_radius_px and tracking.refine_search_radius_px must be at most "
          "1000");
  Require(max_descriptor_distance > 0 && max_descriptor_distance <= 256,
          "tracking.max_descriptor_distance must lie in 1..256");
  Require(match_ratio > 0.0f && match_ratio <= 1.0f, "tracking.match_ratio must lie in (0, 1]");
  Require(min_matches >= 6, "tracking.min_matches must be at least 6");
  Require(sigma_px > 0.0 && sigma_inverse_depth > 0.0,
          "tracking.sigma_px and tracking.sigma_inverse_depth must be positive");
  Require(depth_calibration_interval > 0,
          "tracking.depth_calibration_interval must be a positive number of keyframes");
  const DepthCorrectionFitOptions& fit = depth_calibration;
  Require(fit.min_pairs > 0 && fit.max_residual_m > 0.0 && fit.max_delta > 0.0,
          "tracking.depth_calibration_min_pairs, tracking.depth_calibration_max_residual_m and "
          "tracking.depth_calibration_max_delta must be positive");
  Require(fit.coefficient_sigma > 0.0 && fit.residual_sigma_m > 0.0,
          "tracking.depth_calibration_coefficient_sigma and "
          "tracking.depth_calibration_residual_sigma_m must be positive");
  Require(fit.min_spread_reduction >= 0.0 && fit.min_spread_reduction_m >= 0.0,
          "tracking.depth_calibration_min_spread_reduction and "
          "tracking.depth_calibration_min_spread_reduction_m must not be negative");
  Require(fit.joint_min_keyframes >= 2 && fit.joint_min_significance >= 0.0 &&
              fit.joint_max_weakest_sd > 0.0,
          "tracking.depth_calibration_joint_min_keyframes must be at least 2, "
          "tracking.depth_calibration_joint_min_significance not negative and "
          "tracking.depth_calibration_joint_max_weakest_sd positive");
  Require(far_depth > 0.0 && far_depth_power >= 0.0,
          "tracking.far_depth must be positive and tracking.far_depth_power not negative");
  Require(min_landmark_depth > 0.0 && max_landmark_depth > min_landmark_depth,
          "tracking.max_landmark_depth must exceed tracking.min_landmark_depth (> 0)");
}

void TrackerOptions::ValidateKeyframes() const {
  Require(keyframe_ratio > 0.0 && keyframe_ratio <= 1.0,
          "tracking.keyframe_ratio must lie in (0, 1]");
  Require(max_keyframe_interval >= 1 && min_keyframe_interval >= 1 &&
              min_keyframe_interval <= max_keyframe_interval,
          "tracking.min_keyframe_interval must lie in 1..tracking.max_keyframe_interval");
  Require(min_keyframe_inliers >= 0 && close_tracked_max >= 0 && close_untracked_min >= 0,
          "tracking.min_keyframe_inliers, tracking.close_tracked_max and "
          "tracking.close_untracked_min must not be negative");
  Require(cull_found_ratio >= 0.0 && cull_found_ratio <= 1.0 && cull_min_visible >= 1 &&
              cull_single_view_age >= 1 && cull_recent_age >= cull_single_view_age,
          "tracking.cull_found_ratio must lie in [0, 1], tracking.cull_min_visible and "
          "tracking.cull_single_view_age be at least 1, tracking.cull_recent_age at least "
          "tracking.cull_single_view_age");
  Require(local_window >= 2 && local_map_keyframes >= 1,
          "tracking.local_window must be at least 2 and tracking.local_map_keyframes at least 1");
  Require(bundle_adjustment_handover_frames >= 0 && bundle_adjustment_handover_frames <= 1000,
          "tracking.bundle_adjustment_handover_frames must be 0..1000");
  Require(weak_tracking_inliers >= 0, "tracking.weak_tracking_inliers must not be negative");
  Require(close_depth > 0.0, "tracking.close_depth must be positive");
  Require(pnp.max_reprojection_error > 0.0 && pnp.refine_reprojection_error > 0.0,
          "tracking.pnp_max_reprojection_error and tracking.pnp_refine_reprojection_error must "
          "be positive");
  Require(pnp.iterations >= 1 && pnp.iterations <= 100000,
          "tracking.pnp_iterations must be 1..100000");
  Require(pnp.confidence > 0.0 && pnp.confidence < 1.0,
          "tracking.pnp_confidence must be in (0, 1)");
  Require(pnp.min_inliers >= 4, "tracking.pnp_min_inliers must be at least 4");
  Require(refinement.rounds >= 1 && refinement.rounds <= 20 &&
              refinement.iterations_per_round >= 1 && refinement.iterations_per_round <= 1000,
          "tracking.refinement_rounds must be 1..20 and tracking.refinement_iterations_per_round "
          "1..1000");
  Require(refinement.chi2_without_depth > 0.0 && refinement.chi2_with_depth > 0.0,
          "tracking.refinement_chi2_without_depth and tracking.refinement_chi2_with_depth must "
          "be positive");
  Require(refinement.min_inliers >= 4, "tracking.refinement_min_inliers must be at least 4");
  Require(bundle_adjustment.iterations_first >= 1 && bundle_adjustment.iterations_first <= 1000 &&
              bundle_adjustment.iterations_second >= 1 &&
              bundle_adjustment.iterations_second <= 1000,
          "tracking.bundle_adjustment_iterations_first and _second must be 1..1000");
  Require(bundle_adjustment.chi2_without_depth > 0.0 && bundle_adjustment.chi2_with_depth > 0.0,
          "tracking.bundle_adjustment_chi2_without_depth and _chi2_with_depth must be positive");
}

void TrackerOptions::ValidateLoops() const {
  Require(min_tracked >= 6 && min_relocalized >= min_tracked,
          "tracking.min_tracked must be at least 6 and at most tracking.min_relocalized");
  Require(relocalization_keyframes >= 1, "tracking.relocalization_keyframes must be at least 1");
  Require(new_map_after_lost >= 1, "tracking.new_map_after_lost must be at least 1");
  Require(min_initial_points >= 20, "tracking.min_initial_points must be at least 20");
  Require(
      min_static_depth_share >= 0.0 && min_static_depth_share <= 1.0 && max_predicted_frames >= 0,
      "tracking.min_static_depth_share must lie in [0, 1] and tracking.max_predicted_frames "
      "not be negative");
  Require(redundant_radius_m >= 0.0 && redundant_axis_angle_deg >= 0.0 &&
              redundant_axis_angle_deg <= 180.0,
          "tracking.redundant_radius_m must not be negative and tracking.redundant_axis_angle_deg "
          "lie in 0..180");
  Require(redundant_keyframe_share > 0.0 && redundant_keyframe_share <= 1.0 &&
              redundant_view_angle_deg >= 0.0 && redundant_view_angle_deg <= 180.0 &&
              redundant_scale_ratio >= 1.0,
          "tracking.redundant_keyframe_share must lie in (0, 1], "
          "tracking.redundant_view_angle_deg in 0..180 and tracking.redundant_scale_ratio be at "
          "least 1");
  Require(redundant_retire_keyframes >= local_window && redundant_retire_keyframes <= 10000,
          "tracking.redundant_retire_keyframes must be tracking.local_window..10000");
  Require(landmark_merge_distance_m >= 0.0,
          "tracking.landmark_merge_distance_m must not be negative");
  place.Validate();
  Require(place_candidates >= 1 && place_min_votes >= 1,
          "tracking.place_candidates and tracking.place_min_votes must be at least 1");
  Require(loop_min_inliers >= min_tracked && loop_consistency >= 1 && loop_min_separation >= 1,
          "tracking.loop_min_inliers must be at least tracking.min_tracked, "
          "tracking.loop_consistency and tracking.loop_min_separation at least 1");
  Require(loop_max_drift_m >= 0.0 && loop_max_drift_share >= 0.0 && loop_max_drift_deg >= 0.0 &&
              loop_max_drift_deg_per_m >= 0.0,
          "tracking.loop_max_drift_m, _share, _deg and _deg_per_m must not be negative");
  Require(pose_graph_min_shared >= 1 && pose_graph.iterations >= 1 &&
              pose_graph.iterations <= 1000 && pose_graph.translation_sigma_m > 0.0 &&
              pose_graph.rotation_sigma_rad > 0.0,
          "tracking.pose_graph_min_shared must be at least 1, tracking.pose_graph_iterations "
          "1..1000 and the pose graph's sigmas positive");
  Require(loop_handover_frames >= 0 && loop_handover_frames <= 1000 &&
              global_bundle_adjustment_handover_frames >= 0 &&
              global_bundle_adjustment_handover_frames <= 1000,
          "tracking.loop_handover_frames and "
          "tracking.global_bundle_adjustment_handover_frames must be 0..1000");
  Require(relocalization_max_distance_m > 0.0 && relocalization_max_speed_mps >= 0.0,
          "tracking.relocalization_max_distance_m must be positive and "
          "tracking.relocalization_max_speed_mps not negative");
}

void TrackerOptions::Validate() const {
  features.Validate();
  ValidateMatching();
  ValidateKeyframes();
  ValidateLoops();
}

}  // namespace stillmap
