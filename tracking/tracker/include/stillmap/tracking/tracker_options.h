// The tracker's options, nested by part: the solvers (features, PnP, refinement, bundle
// adjustment), matching and the observation model, keyframes and the local map, relocalization,
// and place recognition and loop closure (loop_closure.h). Their keys stay flat under
// "tracking." (config.yaml lists them in this order).
#pragma once

#include "stillmap/tracking/bundle_adjustment.h"
#include "stillmap/tracking/depth_correction.h"
#include "stillmap/tracking/features.h"
#include "stillmap/tracking/floor_normal.h"
#include "stillmap/tracking/loop_closure.h"
#include "stillmap/tracking/planar_motion.h"
#include "stillmap/tracking/pose_estimation.h"
#include "stillmap/tracking/pose_refinement.h"
#include "stillmap/tracking/rgbd_odometry.h"

namespace stillmap {

// Data association by projection, the RGB-D residual's noise, the depth self-calibration and
// the depth range landmarks are made from.
struct MatchingOptions {
  // Data association by projection.
  double search_radius_px = 15.0;        // around the predicted position (constant velocity)
  double wide_search_radius_px = 50.0;   // second try when the first finds too few matches
  double refine_search_radius_px = 4.0;  // after the first pose, for landmarks not matched yet
  int max_descriptor_distance = 80;      // Hamming, of 256 bits
  float match_ratio = 0.9f;
  int min_matches = 30;

  // Observation noise for the RGB-D residual (pixels are scaled by the keypoint's octave).
  double sigma_px = 1.0;
  double sigma_inverse_depth = 0.0025;  // [1/m]: 2.5 mm at 1 m, 10 mm at 2 m
  // Optional: beyond far_depth the inverse-depth noise is multiplied by (z / far_depth)^
  // far_depth_power (0: off, the default), which weakens far depth as ORB-SLAM2's ThDepth does
  // (measured in docs/figures.md, "Tracker options' measurements").
  double far_depth = 2.0;  // [m]
  double far_depth_power = 0.0;

  // Depth self-calibration (depth_correction.h): every depth_calibration_interval keyframes the
  // depth correction is refitted from the local map's landmarks seen with depth in two keyframes,
  // and used from then on for every depth reading.
  bool depth_self_calibration = true;
  // Estimate the correction jointly with the poses and points in the local bundle adjustment
  // (Teichman et al.) instead of fitting it to the poses every depth_calibration_interval
  // keyframes: poses that bent to the uncorrected depth bias the separate fit towards zero.
  bool depth_calibration_in_bundle_adjustment = true;
  int depth_calibration_interval = 1;
  DepthCorrectionFitOptions depth_calibration;

  // Landmarks are created from keyframe depth within this range [m].
  double min_landmark_depth = 0.1;
  double max_landmark_depth = 12.0;  // far points pin the rotation down

  // Throws InputError naming the first impossible value (tracker_options.cpp).
  void Validate() const;

  // Every field under its configuration key (io/option_fields.h).
  template <typename Self, typename Visitor>
  static void VisitFields(Self& self, Visitor& visit) {
    visit("search_radius_px", self.search_radius_px,
          "projection search radius around the prediction [px]");
    visit("wide_search_radius_px", self.wide_search_radius_px,
          "second, wider projection search radius [px]");
    visit("refine_search_radius_px", self.refine_search_radius_px,
          "search radius for landmarks not matched yet, after the first pose [px]");
    visit("max_descriptor_distance", self.max_descriptor_distance,
          "largest Hamming distance of a match (of 256 bits)");
    visit("match_ratio", self.match_ratio, "best / second-best distance within the search window");
    visit("min_matches", self.min_matches, "fewer matches after the wide search: relocalize");
    visit("sigma_px", self.sigma_px, "keypoint noise at pyramid level 0 [px]");
    visit("sigma_inverse_depth", self.sigma_inverse_depth,
          "keypoint depth noise, in inverse depth [1/m]");
    visit("far_depth", self.far_depth, "far depth: beyond this depth [m] (see far_depth_power)");
    visit("far_depth_power", self.far_depth_power,
          "inverse-depth noise times (z / far_depth)^this beyond far_depth (0: off)");
    visit("depth_self_calibration", self.depth_self_calibration,
          "estimate and correct the depth sensor's error over the image (depth_correction.h)");
    visit("depth_calibration_in_bundle_adjustment", self.depth_calibration_in_bundle_adjustment,
          "estimate the depth correction in the local bundle adjustment, jointly with the poses "
          "(false: fit it to the poses every depth_calibration_interval keyframes)");
    visit("depth_calibration_interval", self.depth_calibration_interval,
          "refit the depth correction every n keyframes");
    visit.Nested("depth_calibration_", self.depth_calibration);
    visit("min_landmark_depth", self.min_landmark_depth,
          "landmarks are made from depth from this [m]");
    visit("max_landmark_depth", self.max_landmark_depth,
          "landmarks are made from depth up to this [m]");
  }
};

// Keyframes (ORB-SLAM2, RGB-D), the culling of landmarks and keyframes, the local map and the
// local bundle adjustment.
struct LocalMapOptions {
  // Keyframes (ORB-SLAM2, RGB-D): a new keyframe when the inliers fall below keyframe_ratio of
  // the landmarks the reference keyframe tracks well, when few near points are tracked while many
  // are not, or at the latest every max_keyframe_interval frames; never with
  // min_keyframe_inliers or fewer.
  double keyframe_ratio = 0.75;
  int min_keyframe_inliers = 15;  // ORB-SLAM2 (RGB-D)
  // The near-point rule (ORB-SLAM2, RGB-D): fewer than close_tracked_max near points (closer than
  // close_depth) tracked while more than close_untracked_min are not.
  int close_tracked_max = 100;
  int close_untracked_min = 70;
  int max_keyframe_interval = 15;
  // Unless tracking is weak (fewer inliers than weak_tracking_inliers), keyframes are at least
  // min_keyframe_interval frames apart: moving people otherwise trigger the near-point rule in
  // nearly every frame.
  int min_keyframe_interval = 5;
  int weak_tracking_inliers = 50;
  double close_depth = 3.0;  // [m] "near" for the near-point rule

  // Culling of recent landmarks (ORB-SLAM2): dropped when found in fewer than cull_found_ratio of
  // the frames in which they were visible (once visible in cull_min_visible frames), or observed
  // by a single keyframe cull_single_view_age keyframes after their creation; landmarks are
  // recent until cull_recent_age keyframes old.
  double cull_found_ratio = 0.25;
  int cull_min_visible = 4;
  int cull_single_view_age = 2;
  int cull_recent_age = 3;
  // A landmark a keyframe observed nearer than close_depth where a later keyframe's depth check
  // found it moving (a person who has moved on since, not masked when the keyframe was made) is
  // forgotten: matched again, it would pull the camera along with the person
  // (Tracker::ForgetLandmarksFoundMoving). Off by default: bonn_crowd_a without the models
  // gained (18.04 -> 16.86 mm), but the synthetic floors' joins moved, and floor seed 2 lost a
  // segment's tracking (docs/figures.md, fifty-sixth session).
  bool forget_landmarks_found_moving = false;

  int local_map_keyframes = 25;
  // Map reuse (issue 27): besides the local_map_keyframes most recent keyframes, up to as many
  // keyframes covisible with the last frame's matches join the local map, so that a camera
  // coming back over its path tracks against what the map holds of the place.
  // Keyframes grow with the places visited, not with the recording's length: when a keyframe
  // becomes final (it left the local bundle adjustment's window, having served tracking while it
  // was recent), it is culled if keyframes kept before it near its pose (centre within
  // redundant_radius_m, optical axis within redundant_axis_angle_deg) saw more than
  // redundant_keyframe_share of its view: its depth over the image in cells of 16 px, each seen
  // by such a keyframe at the same depth, from a direction within redundant_view_angle_deg and a
  // distance within redundant_scale_ratio of its own. The seed paper's redundancy rule (paper
  // 000, II.D) applied to tracking keyframes, against every keyframe near the pose. A culled
  // keyframe is not fused and leaves the place index; it stays a fixed anchor of the bundle
  // adjustment until redundant_retire_keyframes keyframes are newer, then its frames are posed
  // through the keyframe sharing most landmarks with it. Share 1 = off.
  double redundant_keyframe_share = 0.98;
  int redundant_retire_keyframes = 24;
  double redundant_view_angle_deg = 15.0;
  double redundant_scale_ratio = 1.25;
  double redundant_radius_m = 1.0;
  double redundant_axis_angle_deg = 60.0;
  // A landmark found again as a second copy while tracking (both match one feature within
  // ORB-SLAM2's fusion tests; positions within this [m]) is merged into the one more keyframes
  // observe. 0 = off, the default (it moved the motion model's predictions on the noise-free
  // synthetic room); the loop closure merges the two copies of a place it joins in any case.
  double landmark_merge_distance_m = 0.0;
  int local_window = 8;
  bool background_bundle_adjustment = true;  // false: solve it inline (same result, slower)
  // Frames after its request when a local bundle adjustment's result is taken (sooner at the
  // next keyframe): a point fixed by the data, so runs repeat exactly.
  int bundle_adjustment_handover_frames = 4;

  // Throws InputError naming the first impossible value (tracker_options.cpp).
  void Validate() const;

  // Every field under its configuration key (io/option_fields.h).
  template <typename Self, typename Visitor>
  static void VisitFields(Self& self, Visitor& visit) {
    visit("keyframe_ratio", self.keyframe_ratio,
          "new keyframe when inliers fall below this share of the reference's landmarks "
          "(ORB-SLAM2 RGB-D: 0.75)");
    visit("min_keyframe_inliers", self.min_keyframe_inliers,
          "no keyframe with this many inliers or fewer (ORB-SLAM2 RGB-D: 15)");
    visit("close_tracked_max", self.close_tracked_max,
          "near-point rule: fewer near points than this tracked (ORB-SLAM2 RGB-D: 100)");
    visit("close_untracked_min", self.close_untracked_min,
          "near-point rule: more near points than this untracked (ORB-SLAM2 RGB-D: 70)");
    visit("max_keyframe_interval", self.max_keyframe_interval,
          "a keyframe at least every this many frames");
    visit("min_keyframe_interval", self.min_keyframe_interval,
          "keyframes at least this many frames apart unless tracking is weak");
    visit("weak_tracking_inliers", self.weak_tracking_inliers,
          "tracking is weak with fewer inliers (min_keyframe_interval does not apply)");
    visit("close_depth", self.close_depth, "near-point rule: near means closer than this [m]");
    visit("cull_found_ratio", self.cull_found_ratio,
          "recent landmarks found in fewer than this share of their visible frames go");
    visit("cull_min_visible", self.cull_min_visible,
          "frames a landmark must be visible in before that rule");
    visit("cull_single_view_age", self.cull_single_view_age,
          "keyframes after which a landmark seen by one keyframe only goes");
    visit("cull_recent_age", self.cull_recent_age, "keyframes a landmark stays subject to culling");
    visit("forget_landmarks_found_moving", self.forget_landmarks_found_moving,
          "forget the landmarks a keyframe observed nearer than close_depth where a later "
          "keyframe found it moving (a person not masked then)");
    visit("local_map_keyframes", self.local_map_keyframes,
          "keyframes whose landmarks are searched for per frame");
    visit("redundant_keyframe_share", self.redundant_keyframe_share,
          "a keyframe becoming final is culled when keyframes kept before it near its pose saw "
          "more than this share of its view (paper 000's redundancy rule; 1 = off)");
    visit("redundant_view_angle_deg", self.redundant_view_angle_deg,
          "similar view: the rays to the point within this angle [deg]");
    visit("redundant_scale_ratio", self.redundant_scale_ratio,
          "similar view: distances to the point within this ratio");
    visit("redundant_retire_keyframes", self.redundant_retire_keyframes,
          "a culled keyframe anchors the bundle adjustment until this many keyframes are newer");
    visit("redundant_radius_m", self.redundant_radius_m,
          "keyframes with their centre within this of the pose are near it [m]");
    visit("redundant_axis_angle_deg", self.redundant_axis_angle_deg,
          "... and their optical axis within this of its own [deg]");
    visit("landmark_merge_distance_m", self.landmark_merge_distance_m,
          "a second copy of a landmark found again within this distance is merged [m]");
    visit("local_window", self.local_window, "keyframes optimized by the local bundle adjustment");
    visit("background_bundle_adjustment", self.background_bundle_adjustment,
          "solve the local bundle adjustment on its own thread (false: inline; same result)");
    visit("bundle_adjustment_handover_frames", self.bundle_adjustment_handover_frames,
          "frames after its request when the local bundle adjustment's result is taken (sooner "
          "at the next keyframe); fixed by the data, so runs repeat exactly");
  }
};

// Tracked, occluded, lost: relocalization near the last good pose, a new local map after a long
// loss, and the first map.
struct RelocalizationOptions {
  int min_tracked = 20;
  int min_relocalized = 30;
  int relocalization_keyframes = 5;
  int new_map_after_lost = 15;
  // Occlusion (issue 17: a person passing the lens): a frame whose share of pixels with a depth
  // reading outside the moving mask is below this makes no keyframe and no landmarks; it is
  // posed from what remains ("occluded") or, when that fails, by the constant-velocity model
  // ("predicted", for at most max_predicted_frames in a row).
  double min_static_depth_share = 0.1;
  int max_predicted_frames = 15;
  // A pose from vision (relocalized or tracked) is taken only within this distance of where the
  // camera was last seen [m], plus relocalization_max_speed_mps for each second since then: a
  // match on a look-alike view elsewhere, or a few matches on a repeating pattern, would put a
  // jump in the trajectory.
  double relocalization_max_distance_m = 0.3;
  double relocalization_max_speed_mps = 1.5;
  // While lost for at most motion_model_horizon_s, the last good pose moved on by its velocity
  // predicts the frame (the search and the dense alignment start there, and the velocity still
  // predicts the frame after a relocalization), and a relocalization farther than
  // motion_model_max_distance_m from that prediction is refused: tiles or a look-alike view
  // matched at the wrong place. Off by default (0): at 0.5 s the synthetic floor's seed 1 gained
  // and seed 2 lost (docs/figures.md, thirtieth session).
  double motion_model_horizon_s = 0.0;
  double motion_model_max_distance_m = 0.15;
  int min_initial_points = 100;
  // A new segment after a loss begins only on a frame with at least this many features with
  // depth outside the moving mask. Past new_map_after_lost frames the map is not searched any
  // more. At 300 a view of a blank wall beside a person nothing masks yet no longer starts a
  // segment that follows the person (floor_lost), but floor seed 2 lost 156 mm: not a default
  // (docs/figures.md, fifty-ninth session).
  int new_map_min_points = 100;

  // Throws InputError naming the first impossible value (tracker_options.cpp).
  void Validate() const;

  // Every field under its configuration key (io/option_fields.h).
  template <typename Self, typename Visitor>
  static void VisitFields(Self& self, Visitor& visit) {
    visit("min_tracked", self.min_tracked, "inliers for a frame to count as tracked");
    visit("min_relocalized", self.min_relocalized, "inliers for a relocalization to be accepted");
    visit("relocalization_keyframes", self.relocalization_keyframes,
          "keyframes a relocalization tries");
    visit("new_map_after_lost", self.new_map_after_lost,
          "consecutive lost frames before a new map segment begins, in a frame of its own");
    visit("min_static_depth_share", self.min_static_depth_share,
          "frames with less depth outside the moving mask make no keyframe (occluded)");
    visit("max_predicted_frames", self.max_predicted_frames,
          "occluded frames posed by the motion model at most this many in a row");
    visit("relocalization_max_distance_m", self.relocalization_max_distance_m,
          "poses from vision (relocalized or tracked) farther than this from the last good one "
          "are refused [m]");
    visit("relocalization_max_speed_mps", self.relocalization_max_speed_mps,
          "... plus this much per second since it [m/s]");
    visit("motion_model_horizon_s", self.motion_model_horizon_s,
          "while lost this long at most, the last good velocity predicts the pose (0: off) [s]");
    visit("motion_model_max_distance_m", self.motion_model_max_distance_m,
          "relocalizations farther than this from that prediction are refused [m]");
    visit("min_initial_points", self.min_initial_points,
          "features with depth needed to start a map");
    visit("new_map_min_points", self.new_map_min_points,
          "features with depth (outside the moving mask) a new segment after a loss begins on");
  }
};

struct TrackerOptions {
  FeatureOptions features;
  PnpOptions pnp;
  RefinementOptions refinement;
  BundleAdjustmentOptions bundle_adjustment;
  MatchingOptions matching;
  LocalMapOptions local_map;
  RelocalizationOptions relocalization;
  RgbdOdometryOptions rgbd_odometry;
  LoopClosureOptions loops;
  // A camera on a ground robot keeps its height and tilt: the final poses are put back on their
  // plane of motion (planar_motion.h). "auto": only when the tracked poses kept to a plane as a
  // robot's do (a hand-held camera's rise and tilt more); "on": always; "off": never.
  PlanarMotionMode planar_motion = PlanarMotionMode::kAuto;
  // ... with the camera's tilt taken from the floor its keyframes see (floor_normal.h).
  FloorNormalOptions planar_floor;

  // Throws InputError naming the first impossible value: each part's, the solvers', and the
  // checks across parts (tracker_options.cpp).
  void Validate() const;

  // Every field under its configuration key (io/option_fields.h), flat under "tracking.".
  template <typename Self, typename Visitor>
  static void VisitFields(Self& self, Visitor& visit) {
    visit.Nested("", self.features);
    visit.Nested("pnp_", self.pnp);
    visit.Nested("refinement_", self.refinement);
    visit.Nested("bundle_adjustment_", self.bundle_adjustment);
    visit.Nested("", self.matching);
    visit.Nested("", self.local_map);
    visit.Nested("", self.relocalization);
    visit.Nested("rgbd_odometry_", self.rgbd_odometry);
    visit.Nested("", self.loops);
    visit("planar_motion", self.planar_motion,
          "auto, on or off: the final poses put on their plane of motion (height and tilt "
          "fixed; x, y and heading as tracked), as a ground robot's camera moves; auto: when the "
          "tracked poses kept within 3 cm of one height and 1 degree of one tilt");
    visit.Nested("planar_motion_floor_", self.planar_floor);
  }
};

}  // namespace stillmap
