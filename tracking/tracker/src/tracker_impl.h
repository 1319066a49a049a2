// Internal to the tracker: its local map's data (landmarks, keyframes) and Tracker::Impl, whose
// methods live in one file per job (frame_data.h holds the current frame and its associations):
// tracker.cpp (per frame), tracker_search.cpp (projection search, pose,
// relocalization), tracker_local_map.cpp (local map, culling, new maps), tracker_keyframes.cpp
// (keyframe policy, final keyframes), tracker_worker.cpp (local bundle adjustment and its
// thread), tracker_depth_calibration.cpp (depth self-calibration), tracker_loops.cpp and
// tracker_loop_correction.cpp (what the loop closure component needs of the map: verification,
// shared landmarks, applying a correction).
#pragma once

#include <algorithm>
#include <array>
#include <chrono>
#include <climits>
#include <condition_variable>
#include <cstdint>
#include <cstring>
#include <deque>
#include <exception>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <thread>
#include <unordered_map>
#include <utility>
#include <vector>

#include "frame_data.h"
#include "frame_records.h"
#include "hamming.h"
#include "stillmap/io/timing.h"
#include "stillmap/tracking/loop_closure.h"
#include "stillmap/tracking/pose_graph.h"
#include "stillmap/tracking/rgbd_odometry.h"
#include "stillmap/tracking/tracker.h"

namespace stillmap {

// The share of pixels with a depth reading outside `ignore_mask` (may be empty).
double StaticDepthShare(const cv::Mat& depth_m, const cv::Mat& ignore_mask);

using Clock = std::chrono::steady_clock;

struct Landmark {
  Eigen::Vector3d position = Eigen::Vector3d::Zero();  // world frame
  Descriptor descriptor{};
  int octave = 0;
  int created_keyframe = 0;
  std::vector<std::pair<int, int>> observations;  // (keyframe id, feature index)
  int visible = 0;                                // frames in which it projected into the image
  int found = 0;                                  // frames in which it was an inlier
  size_t local_stamp = 0;                         // serial of the last local set it was put into
  size_t matched_stamp = 0;                       // match_serial when last matched
};

struct Keyframe {
  int id = 0;
  size_t frame_index = 0;
  double time = 0.0;
  Eigen::Isometry3d camera_from_world = Eigen::Isometry3d::Identity();
  FrameFeatures features;
  std::vector<Descriptor> descriptors;
  std::vector<int> landmark_of_feature;  // landmark id per feature, -1 none
  // The fewest inliers of a frame tracked since the keyframe before (0: one was lost or posed
  // by the motion model): how sure the pose graph's odometry edge to it is.
  int weakest_inliers = INT_MAX;
  bool final = false;
  // Culled (CullIfRedundant): not fused, no place to recognise, but still a fixed anchor of the
  // bundle adjustment until EraseRetired takes it out.
  bool retiring = false;
  // What it saw (SeenDepth), for the redundancy rule: a point counts as seen by this keyframe
  // only at a depth it read there, not behind what stood in front or in a masked region.
  cv::Mat seen_depth;
};
constexpr int kDepthCell = 16;  // [px]

using LocalSet = std::vector<std::pair<int, Landmark*>>;

struct Tracker::Impl {
  Impl(const Camera& camera_in, const TrackerOptions& options_in);
  ~Impl();
  Impl(const Impl&) = delete;
  Impl& operator=(const Impl&) = delete;

  struct PoseEstimate {
    bool ok = false;
    Eigen::Isometry3d camera_from_world = Eigen::Isometry3d::Identity();
    int matches = 0;
    int inliers = 0;
    double rmse_px = 0.0;
  };

  // ---- Per frame: the pose, the bookkeeping of a tracked frame, observations (tracker.cpp)
  double OctaveScale(int octave) const;
  // A pose from vision is plausible: near the last good pose, given the time since (options).
  bool NearLastGoodPose(const Eigen::Isometry3d& camera_from_world, double time) const;
  // A relocalization is plausible: near MotionModelPose where there is one (options).
  bool NearMotionModel(const Eigen::Isometry3d& camera_from_world, double time) const;
  // The i-th feature as an observation, its depth corrected (depth_correction.h) or raw.
  RgbdObservation Observation(const FrameFeatures& features, size_t i,
                              bool raw_depth = false) const;
  double DepthFactor(const Eigen::Vector2d& normalized) const;
  bool UsableDepth(float depth) const;
  TrackResult Track(size_t frame_index, double time, const cv::Mat& gray, const cv::Mat& depth_m,
                    const cv::Mat& ignore_mask);
  // Track's steps: the first map (while there is none); the frame's pose against the local map,
  // else by relocalization near the last good pose; the bookkeeping of a frame with a pose; and
  // of one without (carried by the motion model behind an occluder, else lost, a new map after
  // options.relocalization.new_map_after_lost frames); the frame's end (a tracked frame becomes
  // the reference for dense alignment, the prior is used up, the total time).
  void EndFrame(double time, Clock::time_point start, TrackResult* result);
  void TrackWithoutMap(FrameData& frame, int with_depth, size_t frame_index, double time,
                       std::unique_lock<std::mutex>& lock, TrackResult* result);
  PoseEstimate FindPose(const Eigen::Isometry3d& predicted, const LocalSet& local,
                        const FrameData& frame, double time, Association* association);
  void TakePose(const PoseEstimate& estimate, const LocalSet& local, const FrameData& frame,
                Association* association, TrackResult* result);
  void TrackWithoutPose(const Eigen::Isometry3d& predicted, const LocalSet& local, FrameData& frame,
                        int with_depth, size_t frame_index, double time,
                        std::unique_lock<std::mutex>& lock, TrackResult* result);
  void DropUnconfirmedPredictions();
  // Features found no pose: the frame's depth aligned to the last posed frame's
  // (rgbd_odometry.h), from the prediction. On success the frame is posed (kDepth), becomes a
  // keyframe every rgbd_odometry.keyframe_interval frames (with the local landmarks found by
  // projection from that pose) and true is returned (tracker_rgbd_odometry.cpp).
  bool TrackByRgbdOdometry(const Eigen::Isometry3d& predicted, const LocalSet& local,
                           FrameData& frame, int with_depth, size_t frame_index, double time,
                           std::unique_lock<std::mutex>& lock, TrackResult* result);
  // The frame's camera_from_world by dense alignment to the last posed frame, from the
  // prediction; none when there is no such frame, it is older than rgbd_odometry.max_gap_s or
  // the alignment is refused.
  std::optional<Eigen::Isometry3d> DensePose(const Eigen::Isometry3d& predicted, double time);
  // A weak feature pose (fewer inliers than rgbd_odometry.check_below_inliers) checked against
  // the dense alignment to the last posed frame: where they disagree, the dense pose replaces
  // it and the frame's matches are those found by projection from that pose that fit it, when
  // at least check_min_landmarks do (tracker_rgbd_odometry.cpp).
  void CheckByRgbdOdometry(const Eigen::Isometry3d& predicted, const LocalSet& local,
                           const FrameData& frame, double time, PoseEstimate* estimate,
                           Association* association);
  // *association becomes the local landmarks found by projection from `dense` that fit it;
  // returns how many, and their RMS reprojection error [px].
  int MatchAtDensePose(const Eigen::Isometry3d& dense, const LocalSet& local,
                       const FrameData& frame, Association* association, double* rmse_px);
  // The predicted camera_from_world of the frame at `time`: constant velocity from `last`, else
  // the prior's motion since the last posed frame, else (lost) MotionModelPose
  // (tracker_prior.cpp).
  Eigen::Isometry3d Predict(const Eigen::Isometry3d& last, double time) const;
  // The last good pose moved on by its velocity for the time since, while that is within
  // relocalization.motion_model_horizon_s (the rotation's angle and the translation scaled).
  std::optional<Eigen::Isometry3d> MotionModelPose(double time) const;
  // The prior's motion since the last posed frame applied to that frame's pose (needs
  // HasPriorMotion: this frame and the last posed one both have a prior).
  Eigen::Isometry3d PriorPrediction() const;
  bool HasPriorMotion() const { return next_prior && last_good_prior; }
  // Lost for tracking.new_map_after_lost frames: the map is no longer searched, and the next view
  // with enough points begins a new segment.
  bool PastNewMapWait() const {
    return consecutive_lost >= options.relocalization.new_map_after_lost;
  }
  // Projection search around *predicted; when it finds fewer than min_matches, around the
  // prior's prediction (which becomes *predicted when it finds more), then wider.
  void SearchAroundPredictions(Eigen::Isometry3d* predicted, const LocalSet& local,
                               const FrameData& frame, Association* association);
  // Visible / found counts for landmark culling.
  void CountVisibility(const Eigen::Isometry3d& camera_from_world, const LocalSet& local,
                       const Association& association);
  // Bookkeeping for a frame with a pose.
  void Accept(const Eigen::Isometry3d& camera_from_world, double time,
              const std::vector<int>& matched, TrackResult* result);

  // ---- The local map: its landmarks, culling, a new map after a loss (tracker_local_map.cpp)
  // The landmarks of the local keyframes, and those the last frame matched.
  LocalSet CollectLocalLandmarks();
  // The landmarks of a place: those of keyframe_id and of the keyframes sharing most with it.
  LocalSet PlaceLandmarks(int keyframe_id);
  // The local map's keyframes: the current map's most recent, then (map reuse on a revisit)
  // those covisible with the last frame's matches, most shared first.
  std::vector<int> LocalKeyframes() const;
  // Keyframes (with features) whose centre lies within radius_m of the camera's and whose
  // optical axis is within max_angle_deg of its own, in id order.
  std::vector<int> NearbyKeyframes(const Eigen::Isometry3d& camera_from_world, double radius_m,
                                   double max_angle_deg) const;
  // A landmark found again as a second copy (both matched the same feature, close in space) is
  // merged into the older one: its observations move over, the copy goes. Call after
  // CountVisibility (the local set's pointers must not dangle while used).
  void MergeDuplicates(const Eigen::Isometry3d& camera_from_world, const FrameData& frame,
                       Association* association);
  void MergeLandmark(int keep, int drop);
  // ORB-SLAM2's culling of recent map points: found in under a quarter of the frames where they
  // were visible, or seen by a single keyframe two keyframes after their creation.
  void CullRecentLandmarks(int current_keyframe);
  void EraseLandmark(int id);
  size_t ForgetLandmarksFoundMoving(int keyframe_id, const cv::Mat& moving);
  // A new local map whose first keyframe is this frame at camera_from_world.
  void StartMap(const Eigen::Isometry3d& camera_from_world, FrameData& frame, size_t frame_index,
                double time, std::unique_lock<std::mutex>& lock);

  // ---- Projection search, pose estimation and relocalization (tracker_search.cpp)
  // Projects the local landmarks not matched yet with camera_from_world and matches each to the
  // closest descriptor within radius_px (scaled by the landmark's octave). A feature keeps the
  // landmark with the smallest distance.
  void SearchByProjection(const Eigen::Isometry3d& camera_from_world, const LocalSet& local,
                          double radius_px, const FrameData& frame, Association* association);
  // The associated features and their landmarks' positions.
  void GatherAssociations(const Association& association, std::vector<size_t>* features,
                          std::vector<Eigen::Vector3d>* points) const;
  // Motion-only refinement over the associations; drops the outliers from `association`.
  PoseEstimate Refine(const Eigen::Isometry3d& initial, const FrameData& frame,
                      Association* association, const RefinementOptions& refinement);
  // PnP-RANSAC on the associations (falling back to `guess` when allowed), a short refinement, a
  // second projection search around that pose for landmarks not matched yet, and the full
  // refinement over all associations.
  PoseEstimate EstimatePose(const Eigen::Isometry3d& guess, bool guess_usable,
                            const LocalSet& local, const FrameData& frame,
                            Association* association);
  void Unmatch(size_t feature, Association* association);
  // Verifies the place index's candidates, then the most recent keyframes, until one gives a
  // pose with min_relocalized inliers.
  PoseEstimate Relocalize(const FrameData& frame, Association* association);
  // The frame's pose against the place keyframe `keyframe_id` saw: descriptor matches with its
  // landmarks, PnP-RANSAC, the refinement and a projection search in the local map around it.
  // Not ok below min_inliers inliers (the association is then cleared).
  PoseEstimate VerifyPlace(const FrameData& frame, int keyframe_id, int min_inliers,
                           Association* association);

  // ---- Place recognition and loop closure (tracker_loops.cpp)
  // Asks the place index for an earlier place the new keyframe does not share landmarks with,
  // verifies it, and closes the loop once loop_consistency keyframes in a row verified it.
  void DetectLoop(int keyframe_id);
  // The correction a loop would make (the keyframe at camera_from_world instead of where it is)
  // is within what drift could have done over the path from the candidate (options.loop_max_*):
  // a place that only looks like an earlier one would ask for more.
  bool PlausibleDrift(int candidate, int keyframe_id,
                      const Eigen::Isometry3d& camera_from_world) const;
  // Keyframes that share landmarks with `keyframe_id` (itself included), and how many.
  std::map<int, int> SharedLandmarks(int keyframe_id) const;
  // A loop correction (loop_closure.h) is solved on the worker like the bundle adjustment and
  // taken at a point fixed by the data: before the frame loop_handover_frames after the loop was
  // accepted, a new map or Finish. Keyframes made meanwhile move with the loop's keyframe.
  // The pose graph with the loop edge (the keyframe at camera_from_world as verified against
  // `candidate`), handed to the worker (or solved at once without one).
  void RequestLoopCorrection(int keyframe_id, int candidate,
                             const Eigen::Isometry3d& camera_from_world,
                             const Association& association);
  // Takes the pending loop correction (after the pending adjustment, which is in the frame
  // before it), moves keyframes and landmarks, merges the place's two copies and requests a
  // global bundle adjustment (loop_global_bundle_adjustment).
  void TakeLoopCorrection(std::unique_lock<std::mutex>& lock);
  void ApplyLoopCorrection(const LoopCorrection& loop);
  void MergeLoopLandmarks(const LoopCorrection& loop);
  // Tracker::MoveKeyframes, once the pending results are taken.
  void MoveKeyframes(const std::map<int, Eigen::Isometry3d>& world_from_keyframe);
  // Landmarks shared by each pair of keyframes: (older, newer) id -> count.
  std::map<std::pair<int, int>, int> CovisibilityPairs() const;
  void ClearMatches(Association& association);
  // Undoes the matches of *association and takes `earlier`'s again (stamped for this frame).
  void RestoreMatches(const Association& earlier, Association* association);

  // ---- Keyframe policy and insertion, final keyframes (tracker_keyframes.cpp)
  bool NeedKeyframe(const FrameData& frame, const Association& association, int inliers) const;
  // The share of the frame's features with depth that keyframes near the pose already saw from
  // a similar direction and distance (options.redundant_*): the seed paper's redundancy rule,
  // applied to tracking keyframes against every keyframe near the pose.
  // The share of a keyframe's view (its seen_depth cells) that keyframes near it, as `use`
  // picks them, saw from a similar direction and distance at the same depth.
  template <typename Use>
  double CoveredShare(const Keyframe& keyframe, Use&& use) const;
  // What a keyframe saw: per cell of kDepthCell px, the depth range and mean of its static depth
  // readings (CV_32FC3: min, max, mean; 0 where fewer than a quarter of the pixels have one).
  cv::Mat SeenDepth(const cv::Mat& depth_m, const cv::Mat& ignore_mask) const;
  // A keyframe becoming final that keyframes kept before it cover (redundant_keyframe_share) is
  // culled: it is not fused and leaves the place index, and retires.
  bool CullIfRedundant(size_t position);
  // Culled keyframes redundant_retire_keyframes behind the newest (all of them when `all`) are
  // erased: until then the bundle adjustment holds them fixed while it solves the windows near
  // them.
  void EraseRetired(bool all);
  // Erases the culled keyframe at `position`: its observations go, its frames are handed to the
  // kept keyframe sharing most landmarks with it.
  void EraseCulled(size_t position);
  // A keyframe's pose, culled ones through the keyframe they were handed to.
  Eigen::Isometry3d CameraFromWorld(int keyframe_id) const;
  int InsertKeyframe(const Eigen::Isometry3d& camera_from_world, FrameData& frame,
                     const Association& association, size_t frame_index, double time,
                     std::unique_lock<std::mutex>& lock);
  // Keyframes older than both the current window and the window of a running adjustment are
  // final.
  void UpdateFinal(bool all = false);

  // ---- The local bundle adjustment and its worker thread (tracker_worker.cpp)
  // An adjustment is requested at each keyframe with the window as it stands then, solved on the
  // worker (or at once without one), and its result taken at a point fixed by the data: before
  // the frame bundle_adjustment_handover_frames after the request, or the next keyframe, a new
  // map or Finish, whichever comes first. The tracker waits there when the solve is late, so the
  // poses never depend on how fast the worker was.
  struct ObservationRef {
    int keyframe_id, feature, landmark_id;
  };
  struct SolvedWindow {
    BundleAdjustmentResult result;
    std::exception_ptr error;
    double ms = 0.0;
  };
  struct WindowAdjustment {
    BundleAdjustmentProblem problem;  // moved to the solver
    std::vector<int> keyframe_ids, landmark_ids;
    std::vector<ObservationRef> refs;  // per observation of the problem
    std::vector<bool> fixed;           // per keyframe of the problem
    bool calibrating = false;          // the depth correction is estimated jointly
    int window_first = INT_MAX;        // first keyframe id of the window
    size_t handover_serial = 0;        // taken before the frame with this frame_serial
    bool global = false;               // the whole local map, after a loop correction
    bool is_solved = false;
    SolvedWindow solved;
  };
  void WorkerLoop();
  SolvedWindow Solve(BundleAdjustmentProblem problem) const;
  // The problem over the local map's last `window` keyframes; nothing when the map has fewer
  // than two keyframes.
  std::optional<WindowAdjustment> PrepareAdjustment(size_t window) const;
  // Prepares an adjustment (the local window, or the whole local map when `global`) and hands it
  // to the worker (or solves it at once without one).
  void RequestAdjustment(bool global = false);
  // A global adjustment runs across keyframes: it is taken at its handover frame, and the
  // keyframes made before then request no local one (it covers their window).
  bool GlobalAdjustmentRunning() const;
  // Takes the pending adjustment's result (waiting for it when needed) and writes it back.
  void TakeAdjustment(std::unique_lock<std::mutex>& lock);
  void ApplyAdjustment(const WindowAdjustment& adjustment);
  void RejectObservation(const ObservationRef& ref);

  // ---- Depth self-calibration (tracker_depth_calibration.cpp)
  // Refits the depth correction from every pair of consecutive observations with depth of the
  // local map's landmarks (raw depths, current keyframe poses).
  void CalibrateDepth();
  // Solves a local bundle adjustment problem; one that estimates the depth correction returns
  // it only when the window pins it down (else it is solved again with the correction fixed).
  BundleAdjustmentResult SolveWindow(BundleAdjustmentProblem problem) const;

  // ---- State
  Camera camera;
  TrackerOptions options;
  std::vector<double> octave_scale;

  mutable std::mutex mutex;  // guards everything below
  std::unordered_map<int, Landmark> landmarks;
  std::map<int, Keyframe> keyframes;
  std::vector<int> map_keyframes;  // the current local map's keyframes, oldest first
  std::deque<int> recent_landmarks;
  int next_landmark = 0;
  int next_keyframe = 0;
  bool have_map = false;
  size_t next_final = 0;  // position in map_keyframes of the first keyframe not final yet
  std::vector<FinalKeyframe> final_queue;
  struct Culled {
    int parent = 0;  // the keyframe its frames are posed through
    Eigen::Isometry3d camera_from_parent = Eigen::Isometry3d::Identity();
  };
  std::map<int, Culled> culled;

  LoopClosure loops;  // the place index and the loop's consistency (loop_closure.h)
  size_t frame_serial = 0;
  size_t match_serial = 0;  // a landmark matched under this serial is taken (Landmark)
  size_t collect_serial = 0;
  bool have_last = false;
  Eigen::Isometry3d last_camera_from_world = Eigen::Isometry3d::Identity();
  bool have_velocity = false;  // at the last good pose (kept through a short loss)
  Eigen::Isometry3d velocity = Eigen::Isometry3d::Identity();
  double velocity_dt_s = 0.0;  // the time the velocity's motion took
  bool have_good = false;
  Eigen::Isometry3d last_good_camera_from_world = Eigen::Isometry3d::Identity();
  int consecutive_lost = 0;
  int consecutive_predicted = 0;  // frames posed by the motion model in a row
  // Their records [begin, end) and the last good pose before them (DropUnconfirmedPredictions).
  PredictionRun prediction_run;
  // Given poses (Tracker::SetPrior): the next frame's, and the last posed frame's.
  std::optional<Eigen::Isometry3d> next_prior, last_good_prior;
  double last_good_time = 0.0;
  int frames_since_keyframe = 0;
  int weakest_inliers_since_keyframe = INT_MAX;  // Keyframe::weakest_inliers of the next one
  std::vector<int> last_frame_landmarks;
  // This frame's images, and the last posed frame's (its pose: last_good_camera_from_world)
  // with the camera's cells, made on first use: what TrackByRgbdOdometry aligns.
  RgbdImages current_images, reference_images;
  double reference_time = 0.0;
  std::unique_ptr<CellCamera> cell_camera;
  // Where this frame's projection search found a second landmark for a feature besides the one
  // it kept: candidates for MergeDuplicates.
  struct Duplicate {
    size_t feature;
    int landmark;
    int distance;  // Hamming, to the feature
  };
  std::vector<Duplicate> duplicates;
  std::vector<FrameRecord> records;
  TrackerStatistics stats;
  // Normalized coordinates of the image's corners, edge midpoints and centre: where the depth
  // correction is bounded.
  std::vector<Eigen::Vector2d> image_outline;

  std::thread worker;
  std::condition_variable wake;     // the worker waits for a request
  std::condition_variable ba_done;  // TakeAdjustment waits for the worker
  bool ba_requested = false;        // the pending adjustment waits for the worker
  bool loop_requested = false;      // the pending loop correction waits for the worker
  std::optional<LoopCorrection> pending_loop;
  bool ba_running = false;
  bool stopping = false;
  std::optional<WindowAdjustment> pending;  // requested, not taken yet
  int running_window_first = INT_MAX;       // first keyframe id of the pending one's window
};

}  // namespace stillmap
