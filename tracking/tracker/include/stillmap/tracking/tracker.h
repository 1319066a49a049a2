// The RGB-D camera tracker: ORB features matched by projection against a local map of landmarks
// (constant-velocity prediction), PnP-RANSAC and Ceres motion-only refinement per frame,
// keyframes in the spirit of ORB-SLAM2, and a local bundle adjustment over a sliding window of
// keyframes that runs on its own thread so that it never stalls tracking.
//
// World frame: the first tracked camera frame. When tracking is lost and relocalization against
// recent keyframes fails for a while, a new local map starts at the last good pose, whose true
// place is unknown: the build makes it a map segment of its own (map_segments.h), placed when its
// places are found in an earlier segment (MoveKeyframes).
#pragma once

#include <Eigen/Geometry>
#include <climits>
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
#include "stillmap/tracking/loop_closure.h"
#include "stillmap/tracking/place_index.h"
#include "stillmap/tracking/pose_estimation.h"
#include "stillmap/tracking/pose_graph.h"
#include "stillmap/tracking/pose_refinement.h"
#include "stillmap/tracking/tracker_options.h"

namespace stillmap {

enum class TrackStatus {
  kInitialized,  // first frame of the first local map (identity pose)
  kTracked,
  kRelocalized,   // tracked again after being lost, against a recent keyframe
  kNewMap,        // a new local map chained to the last good pose
  kOccluded,      // too little static depth: posed from what remains, no keyframe
  kPredicted,     // too little static depth and nothing to track: the motion model's pose
  kCarried,       // vision failed: the given poses' motion carried the pose (SetPrior)
  kRgbdOdometry,  // features found no pose: dense RGB-D alignment to the last posed frame
  kLost,          // no pose: nothing is written for this frame
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
  // The fewest inliers of a frame tracked since the keyframe before it, culled ones included
  // (0: one was lost or posed by the motion model): how sure the step to it is.
  int weakest_inliers = INT_MAX;
};

// A loop the tracker corrected: the keyframe that closed it, the earlier place, the correction.
struct CorrectedLoop {
  double time = 0.0;          // the keyframe's timestamp [s]
  double earlier_time = 0.0;  // the earlier place's keyframe's timestamp [s]
  double correction_m = 0.0;  // the keyframe's correction
  double correction_deg = 0.0;
};

struct TrackerStatistics {
  size_t frames = 0;
  size_t tracked = 0;
  size_t lost = 0;
  size_t relocalized = 0;
  size_t new_maps = 0;                 // local maps started after the first
  size_t occluded = 0, predicted = 0;  // frames with too little static depth (TrackStatus)
  size_t carried = 0;                  // frames the given poses carried (TrackStatus::kCarried)
  size_t rgbd_posed = 0;               // frames posed by dense RGB-D odometry (kRgbdOdometry)
  size_t rgbd_refused = 0;             // its alignments tried and refused (rgbd_odometry.h)
  size_t rgbd_checked = 0;             // weak feature poses checked by dense alignment
  size_t rgbd_replaced = 0;            // ... and replaced by it
  size_t rgbd_unconfirmed = 0;         // ... or kept: too few landmarks fit the dense pose
  double rgbd_odometry_ms = 0.0;       // their time, on the tracking thread
  size_t relocalizations_refused = 0;  // too far from the last good pose
  size_t jumps_refused = 0;            // tracked poses as far: refused, the frame is not tracked
  size_t keyframes = 0;
  size_t keyframes_culled = 0;  // keyframes culled when final: their view was covered
  size_t landmarks = 0;         // alive now
  size_t landmarks_merged = 0;  // second copies found again and merged
  size_t landmarks_created = 0;
  size_t landmarks_culled = 0;
  size_t landmarks_found_moving = 0;  // of them, forgotten where a later keyframe found motion
  // Place recognition and loop closure.
  size_t loop_candidates = 0;      // keyframes the place index proposed and verification tried
  size_t loops_verified = 0;       // candidates that passed the geometric verification
  size_t loops_accepted = 0;       // loops corrected (verified loop_consistency times in a row)
  size_t loops_rejected = 0;       // candidates that failed verification
  size_t loops_implausible = 0;    // verified, but asking for more correction than drift explains
  double loop_correction_m = 0.0;  // largest keyframe correction of an accepted loop
  double loop_correction_deg = 0.0;
  std::vector<CorrectedLoop> loops_corrected;  // in the order they were taken
  double loop_ms = 0.0;        // place queries and verification, on the tracking thread
  double loop_solve_ms = 0.0;  // pose graphs, on whichever thread ran them
  size_t segment_moves = 0;    // keyframes moved from outside (MoveKeyframes)
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

// What the tracker holds [bytes], for the run report's memory breakdown: the containers'
// capacities and the images' sizes, not the allocator's overhead.
struct TrackerMemory {
  size_t keyframes = 0;    // features, descriptors and seen depth of every keyframe kept
  size_t landmarks = 0;    // landmarks with their observations
  size_t place_index = 0;  // the loop closure's place index
  size_t frames = 0;       // every tracked frame's pose relative to its keyframe
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

  // A prior for the next frame (poses.use=prior): its pose from outside (a robot's odometry,
  // world_from_camera in that source's own world), or nothing when it has none. Only its motion
  // since the last posed frame is used: the next frame is predicted by it instead of by constant
  // velocity, and where vision fails that prediction is the frame's pose (kCarried), so that no
  // frame is lost and no new local map begins while the prior lasts. Call before PredictedPose
  // and Track; Track takes it.
  void SetPrior(const std::optional<Eigen::Isometry3d>& given_world_from_camera);

  // The prediction of the next frame's pose (camera-to-world): the prior's motion when there is
  // one, else constant velocity; nothing when there is no map yet or the last frame was lost
  // (and no prior carries it).
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
  TrackerMemory memory() const;
  // The depth sensor's correction as the self-calibration has it now (statistics() without the
  // rest, cheap enough for every frame).
  DepthCorrection depth_correction() const;

  // Every keyframe's current pose (camera-to-world) by keyframe id: after Finish, the final
  // ones, loop corrections included.
  std::map<int, Eigen::Isometry3d> KeyframePoses() const;

  // Moves keyframes to poses found outside the tracker (a map segment joined to an earlier one:
  // map_segments.h), camera-to-world by keyframe id, after taking what the worker had pending.
  // Landmarks move with the keyframe that made them. When the newest keyframe moved belongs to
  // the current local map, its keyframes made since and the camera move with it. Counts as a
  // pose correction.
  void MoveKeyframes(const std::map<int, Eigen::Isometry3d>& world_from_keyframe);

  // The pixels of keyframe `keyframe_id` that a later keyframe found moving (the masking's
  // FoundMoving; CV_8UC1, 255 = moving, the keyframe's image size): the landmarks it observed
  // there are forgotten (tracking.forget_landmarks_found_moving). Returns how many.
  size_t ForgetLandmarksFoundMoving(int keyframe_id, const cv::Mat& moving);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace stillmap
