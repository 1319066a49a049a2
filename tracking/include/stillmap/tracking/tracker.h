// The RGB-D camera tracker: ORB features matched by projection against a local map of landmarks
// (constant-velocity prediction), PnP-RANSAC and Ceres motion-only refinement per frame,
// keyframes in the spirit of ORB-SLAM2, and a local bundle adjustment over a sliding window of
// keyframes that runs on its own thread so that it never stalls tracking.
//
// World frame: the first tracked camera frame. When tracking is lost and relocalization against
// recent keyframes fails for a while, a new local map starts, chained to the last good pose (the
// camera is assumed to be where it was last seen); the report counts these new maps.
#pragma once

#include <Eigen/Geometry>
#include <map>
#include <memory>
#include <opencv2/core.hpp>
#include <optional>
#include <vector>

#include "stillmap/io/camera.h"
#include "stillmap/io/trajectory.h"
#include "stillmap/tracking/bundle_adjustment.h"
#include "stillmap/tracking/depth_correction.h"
#include "stillmap/tracking/features.h"
#include "stillmap/tracking/place_index.h"
#include "stillmap/tracking/pose_estimation.h"
#include "stillmap/tracking/pose_graph.h"
#include "stillmap/tracking/pose_refinement.h"

namespace stillmap {

struct TrackerOptions {
  FeatureOptions features;
  PnpOptions pnp;
  RefinementOptions refinement;
  BundleAdjustmentOptions bundle_adjustment;

  // Data association by projection.
  double search_radius_px = 15.0;        // around the predicted position (constant velocity)
  double wide_search_radius_px = 50.0;   // second try when the first finds too few matches
  double refine_search_radius_px = 4.0;  // after the first pose, for landmarks not matched yet
  int max_descriptor_distance = 80;      // Hamming, of 256 bits
  float match_ratio = 0.9f;              // best / second-best distance within the search window
  int min_matches = 30;                  // fewer after the wide search: relocalize

  // Observation noise for the RGB-D residual (pixels are scaled by the keypoint's octave).
  double sigma_px = 1.0;
  double sigma_inverse_depth = 0.0025;  // [1/m]: 2.5 mm at 1 m, 10 mm at 2 m
  // Optional: beyond far_depth the inverse-depth noise is multiplied by (z / far_depth)^
  // far_depth_power (0: off, the default), which weakens far depth as ORB-SLAM2's ThDepth does.
  // Measured ATE, inline bundle adjustment, defaults vs far_depth 2 m and power 4:
  //   Bonn crowd (Xtion, scene at 2-4 m)      44.3 -> 19.3 mm
  //   TUM teddy (Kinect, 0.7-2 m)               4.8 -> 5.6 mm
  //   synthetic static room (ideal z^2 noise)  4.0 -> 9.0 mm  (issue 4's target: 5 mm)
  //   synthetic walking_xyz                    5.2 -> 7.6 mm
  // Bonn needed it because of the Xtion's depth error over the image, which the depth
  // self-calibration below now corrects (Bonn 44.3 -> 18.3 mm with the defaults).
  double far_depth = 2.0;  // [m]
  double far_depth_power = 0.0;

  // Depth self-calibration (depth_correction.h): every depth_calibration_interval keyframes the
  // depth correction is refitted from the local map's landmarks seen with depth in two keyframes,
  // and used from then on for every depth reading (residuals, new landmarks; the map's
  // back-projection uses the one current when the keyframe is fused). Bonn crowd: interval 1, 2,
  // 5 gave 18.3, 18.6, 22.0 mm; a fit takes about 2 ms (45 fits, 95 ms in all).
  bool depth_self_calibration = true;
  // Estimate the correction jointly with the poses and points in the local bundle adjustment
  // (Teichman et al.) instead of fitting it to the poses every depth_calibration_interval
  // keyframes: poses that bent to the uncorrected depth bias the separate fit towards zero, and
  // where people are in view from the start the separate fit never passes its test. Measured,
  // inline bundle adjustment, separate -> joint: bonn_crowd_a frames 150-449 32.9 -> 14.9 mm,
  // 300-599 (YOLOX) 36.8 -> 12.0 mm, whole 18.6 -> 17.7 mm; TUM teddy 4.7 -> 4.9 mm; synthetic
  // rooms without depth error unchanged (every joint estimate refused). docs/robustness-suite.md.
  bool depth_calibration_in_bundle_adjustment = true;
  int depth_calibration_interval = 1;
  DepthCorrectionFitOptions depth_calibration;

  // Landmarks are created from keyframe depth within this range [m].
  double min_landmark_depth = 0.1;
  double max_landmark_depth =
      12.0;  // far points pin the rotation down (teddy: 4 m gave 9 mm ATE, 12 m 5 mm)

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
  // nearly every frame (walking_xyz, no masking: 185 keyframes in 300 frames with 1, 48 with 5).
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

  int local_map_keyframes = 25;  // keyframes whose landmarks are searched for in each frame
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
  // adjustment until redundant_retire_keyframes keyframes are newer (erased at once, it cost
  // bonn_crowd_a 0.9 mm of ATE), then its frames are posed through the keyframe sharing most
  // landmarks with it. Share 1 = off. Chosen on teddy, its replays, bonn_crowd_a, the robustness
  // suite and the synthetic scenarios (docs/figures.md).
  double redundant_keyframe_share = 0.98;
  int redundant_retire_keyframes = 24;
  double redundant_view_angle_deg = 15.0;
  double redundant_scale_ratio = 1.25;
  double redundant_radius_m = 1.0;
  double redundant_axis_angle_deg = 60.0;
  // A landmark found again as a second copy while tracking (both match one feature within
  // ORB-SLAM2's fusion tests; positions within this [m]) is merged into the one more keyframes
  // observe. 0 = off, the default: on the noise-free synthetic room it moved the motion model's
  // predictions by up to 3 mm (tests/tracking/tracker_test.cpp). The loop closure merges the two
  // copies of a place it joins in any case.
  double landmark_merge_distance_m = 0.0;
  int local_window = 8;                      // keyframes optimized by the local bundle adjustment
  bool background_bundle_adjustment = true;  // false: solve it inline (same result, slower)
  // Frames after its request when a local bundle adjustment's result is taken (sooner at the
  // next keyframe): a point fixed by the data, so runs repeat exactly. The solve takes about 3
  // frames of tracking on two cores (bonn_crowd_a), so at 4 the tracker rarely waits for it.
  int bundle_adjustment_handover_frames = 4;

  int min_tracked = 20;      // inliers for a frame to count as tracked
  int min_relocalized = 30;  // inliers for a relocalization to be accepted
  int relocalization_keyframes = 5;
  int new_map_after_lost = 15;  // consecutive lost frames before a new local map is started
  // Occlusion (issue 17: a person passing the lens): a frame whose share of pixels with a depth
  // reading outside the moving mask is below this makes no keyframe and no landmarks; it is
  // posed from what remains ("occluded") or, when that fails, by the constant-velocity model
  // ("predicted", for at most max_predicted_frames in a row).
  double min_static_depth_share = 0.1;
  int max_predicted_frames = 15;
  // A relocalized pose is taken only within this distance of where the camera was last seen
  // [m], plus relocalization_max_speed_mps for each second since then: a match on a look-alike
  // view elsewhere would put a jump in the trajectory.
  double relocalization_max_distance_m = 0.3;
  double relocalization_max_speed_mps = 1.5;
  int min_initial_points = 100;  // features with depth needed to start a map

  // Place recognition (place_index.h) and loop closure (issue 27). Every keyframe's descriptors
  // go into the place index; a relocalization verifies the place_candidates keyframes with most
  // votes (at least place_min_votes) besides the most recent ones. Each new keyframe asks the
  // index for an earlier place it does not share landmarks with (at least loop_min_separation
  // keyframes older); a candidate is verified geometrically (descriptor matches, PnP-RANSAC, the
  // RGB-D refinement and a projection search around it: at least loop_min_inliers inliers), and
  // a loop is accepted only when loop_consistency keyframes in a row verify the same place. The
  // pose graph over all keyframes (odometry edges, covisibility edges between keyframes sharing
  // pose_graph_min_shared landmarks, the loop edge) is solved on the bundle adjustment's worker
  // and taken loop_handover_frames later: keyframes and landmarks move (those made meanwhile with
  // the loop's keyframe), the two copies of the place's landmarks are merged, and a global bundle
  // adjustment over the local map follows, taken global_bundle_adjustment_handover_frames later.
  PlaceIndexOptions place;
  int place_candidates = 3;
  int place_min_votes = 30;
  bool loop_closure = true;
  int loop_min_inliers = 60;
  int loop_consistency = 2;
  int loop_min_separation = 10;
  int pose_graph_min_shared = 100;
  PoseGraphOptions pose_graph;
  int loop_handover_frames = 5;
  bool loop_global_bundle_adjustment = true;
  int global_bundle_adjustment_handover_frames = 30;
  // A verified loop whose correction exceeds what drift could do over the path between its two
  // keyframes is refused (a look-alike place): loop_max_drift_m plus loop_max_drift_share of the
  // path, and loop_max_drift_deg plus loop_max_drift_deg_per_m for each metre of it. stillmap
  // drifts about 1 % of the path (teddy, bonn_crowd_a, the synthetic loop).
  double loop_max_drift_m = 0.1;
  double loop_max_drift_share = 0.05;
  double loop_max_drift_deg = 3.0;
  double loop_max_drift_deg_per_m = 1.0;

  // Throws InputError naming the first impossible value. Its parts: matching and depth,
  // keyframes and the solvers, relocalization, redundancy and loops (tracker_options.cpp).
  void Validate() const;
  void ValidateMatching() const;
  void ValidateKeyframes() const;
  void ValidateLoops() const;

  // Every field under its configuration key (io/option_fields.h).
  template <typename Self, typename Visitor>
  static void VisitFields(Self& self, Visitor& visit) {
    VisitMatchingFields(self, visit);
    VisitKeyframeFields(self, visit);
    VisitLoopFields(self, visit);
  }
  // VisitFields' parts, in the order config.yaml lists them: the solvers, matching and depth;
  // keyframes, culling and the local map; relocalization, places and loops.
  template <typename Self, typename Visitor>
  static void VisitMatchingFields(Self& self, Visitor& visit) {
    visit.Nested("", self.features);
    visit.Nested("pnp_", self.pnp);
    visit.Nested("refinement_", self.refinement);
    visit.Nested("bundle_adjustment_", self.bundle_adjustment);
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
  template <typename Self, typename Visitor>
  static void VisitKeyframeFields(Self& self, Visitor& visit) {
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
  template <typename Self, typename Visitor>
  static void VisitLoopFields(Self& self, Visitor& visit) {
    visit("min_tracked", self.min_tracked, "inliers for a frame to count as tracked");
    visit("min_relocalized", self.min_relocalized, "inliers for a relocalization to be accepted");
    visit("relocalization_keyframes", self.relocalization_keyframes,
          "keyframes a relocalization tries");
    visit("new_map_after_lost", self.new_map_after_lost,
          "consecutive lost frames before a new local map starts at the last good pose");
    visit("min_static_depth_share", self.min_static_depth_share,
          "frames with less depth outside the moving mask make no keyframe (occluded)");
    visit("max_predicted_frames", self.max_predicted_frames,
          "occluded frames posed by the motion model at most this many in a row");
    visit("relocalization_max_distance_m", self.relocalization_max_distance_m,
          "relocalized poses farther than this from the last good one are refused [m]");
    visit("relocalization_max_speed_mps", self.relocalization_max_speed_mps,
          "... plus this much per second since it [m/s]");
    visit("min_initial_points", self.min_initial_points,
          "features with depth needed to start a map");
    visit.Nested("place_", self.place);
    visit("place_candidates", self.place_candidates,
          "best-voted keyframes of the place index verified per query");
    visit("place_min_votes", self.place_min_votes,
          "place index votes a keyframe needs to be verified as a candidate");
    visit("loop_closure", self.loop_closure,
          "detect loops with the place index and correct them with the pose graph");
    visit("loop_min_inliers", self.loop_min_inliers,
          "inliers of a keyframe's pose against an earlier place for a verified loop");
    visit("loop_consistency", self.loop_consistency,
          "keyframes in a row that must verify the same place before a loop is accepted");
    visit("loop_min_separation", self.loop_min_separation,
          "a loop candidate is at least this many keyframes older than the keyframe");
    visit("pose_graph_min_shared", self.pose_graph_min_shared,
          "landmarks two keyframes share for a covisibility edge of the pose graph");
    visit.Nested("pose_graph_", self.pose_graph);
    visit("loop_handover_frames", self.loop_handover_frames,
          "frames after a loop is accepted when its pose graph's result is taken");
    visit("loop_global_bundle_adjustment", self.loop_global_bundle_adjustment,
          "after a loop correction, bundle-adjust the whole local map on the worker");
    visit("global_bundle_adjustment_handover_frames", self.global_bundle_adjustment_handover_frames,
          "frames after its request when the global bundle adjustment's result is taken");
    visit("loop_max_drift_m", self.loop_max_drift_m,
          "a loop's correction may be this much [m] ...");
    visit("loop_max_drift_share", self.loop_max_drift_share,
          "... plus this share of the path between its keyframes (else refused as a look-alike)");
    visit("loop_max_drift_deg", self.loop_max_drift_deg,
          "a loop's rotation correction may be this much [deg] ...");
    visit("loop_max_drift_deg_per_m", self.loop_max_drift_deg_per_m,
          "... plus this much per metre of path between its keyframes [deg/m]");
  }
};

enum class TrackStatus {
  kInitialized,  // first frame of the first local map (identity pose)
  kTracked,
  kRelocalized,  // tracked again after being lost, against a recent keyframe
  kNewMap,       // a new local map chained to the last good pose
  kOccluded,     // too little static depth: posed from what remains, no keyframe
  kPredicted,    // too little static depth and nothing to track: the motion model's pose
  kLost,         // no pose: nothing is written for this frame
};
const char* TrackStatusName(TrackStatus status);

struct TrackTimings {
  double extract_ms = 0.0;
  double match_ms = 0.0;
  double pose_ms = 0.0;
  double keyframe_ms = 0.0;  // keyframe insertion, culling and (inline) bundle adjustment
  double total_ms = 0.0;
};

struct TrackResult {
  TrackStatus status = TrackStatus::kLost;
  Eigen::Isometry3d world_from_camera = Eigen::Isometry3d::Identity();  // valid when tracked()
  int features = 0;
  int matches = 0;
  int inliers = 0;
  double reprojection_rmse_px = 0.0;
  int keyframe_id = -1;             // >= 0 when this frame became a keyframe
  double static_depth_share = 0.0;  // pixels with depth outside the ignore mask
  TrackTimings timings;
  bool tracked() const { return status != TrackStatus::kLost; }
};

// A keyframe whose pose will not change any more (it left the bundle adjustment window).
struct FinalKeyframe {
  int id = 0;
  size_t frame_index = 0;
  double time = 0.0;
  Eigen::Isometry3d world_from_camera = Eigen::Isometry3d::Identity();
  std::vector<int> landmarks;  // ids of the landmarks it observes (for the map's redundancy test)
  // Culled when it became final: keyframes kept before it saw its view
  // (TrackerOptions::redundant_keyframe_share). Not for the map; its frames are posed through
  // the keyframe it handed them to.
  bool culled = false;
  // Its ORB features (not for culled keyframes): what place recognition across sessions matches.
  FrameFeatures features;
};

struct TrackerStatistics {
  size_t frames = 0;
  size_t tracked = 0;
  size_t lost = 0;
  size_t relocalized = 0;
  size_t new_maps = 0;                 // local maps started after the first
  size_t occluded = 0, predicted = 0;  // frames with too little static depth (TrackStatus)
  size_t relocalizations_refused = 0;  // too far from the last good pose
  size_t keyframes = 0;
  size_t keyframes_culled = 0;  // keyframes culled when final: their view was covered
  size_t landmarks = 0;         // alive now
  size_t landmarks_merged = 0;  // second copies found again and merged
  size_t landmarks_created = 0;
  size_t landmarks_culled = 0;
  // Place recognition and loop closure.
  size_t loop_candidates = 0;      // keyframes the place index proposed and verification tried
  size_t loops_verified = 0;       // candidates that passed the geometric verification
  size_t loops_accepted = 0;       // loops corrected (verified loop_consistency times in a row)
  size_t loops_rejected = 0;       // candidates that failed verification
  size_t loops_implausible = 0;    // verified, but asking for more correction than drift explains
  double loop_correction_m = 0.0;  // largest keyframe correction of an accepted loop
  double loop_correction_deg = 0.0;
  double loop_ms = 0.0;        // place queries and verification, on the tracking thread
  double loop_solve_ms = 0.0;  // pose graphs, on whichever thread ran them
  size_t global_bundle_adjustments = 0;
  double global_bundle_adjustment_ms = 0.0;
  double place_index_mib = 0.0;  // memory of the place index
  size_t bundle_adjustments = 0;
  double bundle_adjustment_ms = 0.0;  // total, on whichever thread ran them
  // CPU time of the background thread so far (its adjustments and loop pose graphs) [ms].
  double worker_cpu_ms = 0.0;
  // Results the tracker had to wait for at their handover point, and the time it waited: a slow
  // or busy machine shows here, not in the poses.
  size_t bundle_adjustment_waits = 0;
  double bundle_adjustment_wait_ms = 0.0;
  size_t loop_waits = 0;  // the same for loop corrections
  double loop_wait_ms = 0.0;
  size_t observations_rejected = 0;  // by the bundle adjustment's chi-square test
  // Depth self-calibration: the correction in use and the last fit.
  DepthCorrection depth_correction;
  size_t depth_calibrations = 0;  // fits accepted
  size_t depth_calibrations_refused = 0;
  DepthCorrectionFit last_depth_calibration;
  double depth_calibration_ms = 0.0;  // total, on the tracking thread
};

class Tracker {
 public:
  Tracker(const Camera& camera, const TrackerOptions& options);
  ~Tracker();
  Tracker(const Tracker&) = delete;
  Tracker& operator=(const Tracker&) = delete;

  // Tracks one frame: gray is CV_8UC1, depth_m CV_32FC1 in metres (0 = none), ignore_mask
  // (optional) CV_8UC1, non-zero where pixels must not be used (moving objects).
  TrackResult Track(size_t frame_index, double time, const cv::Mat& gray, const cv::Mat& depth_m,
                    const cv::Mat& ignore_mask = cv::Mat());

  // The constant-velocity prediction of the next frame's pose (camera-to-world), or nothing when
  // there is no map yet or the last frame was lost.
  std::optional<Eigen::Isometry3d> PredictedPose() const;

  // Keyframes whose pose became final since the last call, oldest first.
  std::vector<FinalKeyframe> TakeFinalKeyframes();

  // Waits for the bundle adjustment, runs a last one inline, and makes every keyframe final.
  void Finish();

  // Every tracked frame, camera-to-world, each expressed relative to its reference keyframe so
  // that keyframe corrections carry over. Call after Finish() for the final trajectory.
  Trajectory TrackedTrajectory() const;

  // Loop corrections and global bundle adjustments taken so far: when it changes, keyframes
  // moved (KeyframePoses).
  size_t pose_corrections() const;
  TrackerStatistics statistics() const;
  // The depth sensor's correction as the self-calibration has it now (statistics() without the
  // rest, cheap enough for every frame).
  DepthCorrection depth_correction() const;

  // Every keyframe's current pose (camera-to-world) by keyframe id: after Finish, the final
  // ones, loop corrections included.
  std::map<int, Eigen::Isometry3d> KeyframePoses() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace stillmap
