#include <fmt/format.h>

#include <algorithm>
#include <numeric>
#include <optional>
#include <string>

#include "dense_refinement.h"
#include "floor_up.h"
#include "keyframe_fuser.h"
#include "pose_loops.h"
#include "segment_output.h"
#include "stillmap/io/cpu_usage.h"
#include "stillmap/io/option_names.h"
#include "stillmap/tracking/planar_motion.h"

namespace stillmap {
namespace {

void Record(const TrackResult& result, double time, TrackingFigures* figures) {
  figures->extract_ms.push_back(result.timings.extract_ms);
  figures->match_ms.push_back(result.timings.match_ms);
  figures->pose_ms.push_back(result.timings.pose_ms);
  figures->keyframe_ms.push_back(result.timings.keyframe_ms);
  figures->total_ms.push_back(result.timings.total_ms);
  ++figures->status_counts[TrackStatusName(result.status)];
  if (!result.tracked()) figures->lost_times.push_back(time);
  if (result.status == TrackStatus::kOccluded || result.status == TrackStatus::kPredicted ||
      result.status == TrackStatus::kCarried) {
    figures->flagged_times.push_back(time);
  }
  figures->static_depth_share.push_back(result.static_depth_share);
}

// The segments apart lost again before a keyframe of theirs was kept (TakeLostAgain): their frames
// count as lost, they leave the segments' list, and a warning names each.
void CountLostAgain(const std::vector<ApartSegment>& lost_again, LoopResult* result,
                    TrackingFigures* figures) {
  for (const ApartSegment& segment : lost_again) {
    const SegmentSummary& summary = segment.summary;
    for (const StampedPose& pose : segment.trajectory.poses()) {
      figures->lost_times.push_back(pose.time);
    }
    figures->statistics.tracked -= segment.trajectory.size();
    figures->statistics.lost += segment.trajectory.size();
    result->warnings.push_back(LostAgainWarning(summary));
    std::vector<SegmentSummary>& segments = result->segments;
    segments.erase(std::remove_if(segments.begin(), segments.end(),
                                  [&](const SegmentSummary& s) { return s.id == summary.id; }),
                   segments.end());
    figures->lost_again.push_back(summary);
  }
  std::sort(figures->lost_times.begin(), figures->lost_times.end());
}

// What the tracked loop's own owners hold [bytes] (memory_ledger.h).
std::vector<std::pair<std::string, size_t>> TrackedOwners(const Tracker& tracker,
                                                          const KeyframeFuser& fuser,
                                                          const SegmentKeeper& segments) {
  const TrackerMemory memory = tracker.memory();
  return {{"tracker_keyframes", memory.keyframes},
          {"landmarks", memory.landmarks},
          {"place_index", memory.place_index + segments.segments().MemoryBytes()},
          {"tracked_frame_records", memory.frames},
          {"keyframes_held", fuser.held_bytes()},
          {"keyframe_copies", fuser.stored_bytes()}};
}

// The frames of the map's segments (`in_map`, by frame) and their keyframes put on `plane`.
void SegmentsOntoPlane(const PlanarMotion& plane, const SegmentKeeper& segments,
                       const std::vector<bool>& in_map, Trajectory* trajectory,
                       std::map<int, Eigen::Isometry3d>* world_from_keyframe) {
  std::vector<StampedPose> on_plane = trajectory->poses();
  for (size_t i = 0; i < on_plane.size(); ++i) {
    if (in_map[i]) on_plane[i].world_from_camera = OntoPlane(plane, on_plane[i].world_from_camera);
  }
  *trajectory = Trajectory(std::move(on_plane));
  for (auto& [id, world_from_camera] : *world_from_keyframe) {
    if (segments.KeyframeInMap(id)) world_from_camera = OntoPlane(plane, world_from_camera);
  }
}

// tracking.planar_motion: the poses of the map's segments (`in_map`, by frame) fix the plane of
// motion (nothing when the camera turned too little to find it); their frames and keyframes are
// put on it, in "auto" only when they kept to it as a robot's do, with the camera's tilt from the
// floor its keyframes saw (tracking.planar_motion_floor_enabled). Segments never joined stay as
// tracked, in frames of their own.
void PutOnPlane(const Camera& camera, const TrackerOptions& options, const KeyframeFuser& fuser,
                const SegmentKeeper& segments, const std::vector<bool>& in_map,
                Trajectory* trajectory, std::map<int, Eigen::Isometry3d>* world_from_keyframe,
                TrackingFigures* figures) {
  const std::vector<StampedPose>& tracked = trajectory->poses();
  std::vector<Eigen::Isometry3d> poses;
  poses.reserve(tracked.size());
  for (size_t i = 0; i < tracked.size(); ++i) {
    if (in_map[i]) poses.push_back(tracked[i].world_from_camera);
  }
  figures->planar_motion = FitPlanarMotion(poses);
  figures->planar_motion_refused = !figures->planar_motion && !trajectory->empty();
  if (!figures->planar_motion) return;
  if (options.planar_motion == PlanarMotionMode::kAuto && !KeptToPlane(*figures->planar_motion)) {
    return;
  }
  if (options.planar_floor.enabled) {
    figures->planar_floor = UpFromFloor(camera, fuser, segments, options.planar_floor,
                                        &figures->planar_motion->up_in_camera);
  }
  SegmentsOntoPlane(*figures->planar_motion, segments, in_map, trajectory, world_from_keyframe);
  figures->planar_motion_applied = true;
}

// The map's keyframes kept compact, in time order, as the dense refinement starts from them;
// *kept_index gets each one's index among the fuser's.
std::vector<RefinedKeyframe> MapKeyframes(
    const SegmentKeeper& segments, const KeyframeFuser& fuser,
    const std::vector<double>& run_start_times, const Trajectory& smoothed,
    const std::map<int, Eigen::Isometry3d>& world_from_keyframe, std::vector<size_t>* kept_index) {
  std::vector<RefinedKeyframe> keyframes;
  const std::vector<KeyframeFuser::KeptKeyframe> kept = fuser.KeptKeyframes();
  std::vector<size_t> order(kept.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(),
                   [&kept](size_t a, size_t b) { return kept[a].time < kept[b].time; });
  for (const size_t k : order) {
    if (kept[k].apart || !segments.KeyframeInMap(kept[k].keyframe_id)) continue;
    // Each keyframe starts from where the frames' poses, smoothed, put its stamp, not from where
    // the bundle adjustment put it: the frames are nearer the truth (docs/figures.md), and the
    // frames then follow the refined keyframes by the difference. A keyframe is a frame of the
    // trajectory: nothing is interpolated.
    const auto it = world_from_keyframe.find(kept[k].keyframe_id);
    const Eigen::Isometry3d adjusted =
        it != world_from_keyframe.end() ? it->second : kept[k].world_from_camera;
    // Whether a frame after the keyframe before, up to this one, began tracking anew.
    const auto start = keyframes.empty()
                           ? run_start_times.end()
                           : std::upper_bound(run_start_times.begin(), run_start_times.end(),
                                              keyframes.back().time);
    const bool anew = start != run_start_times.end() && *start <= kept[k].time;
    keyframes.push_back({kept[k].keyframe_id, kept[k].time,
                         smoothed.Interpolate(kept[k].time, 0.0).value_or(adjusted), anew});
    kept_index->push_back(k);
  }
  return keyframes;
}

// final_poses.dense_enabled: the map's keyframes refined by dense alignment of pairs of them, and
// the frames moved with them.
void RefineDensely(const Camera& camera, const DenseRefinementOptions& options, bool parallel,
                   const std::vector<double>& run_start_times, const SegmentKeeper& segments,
                   const KeyframeFuser& fuser, const std::vector<bool>& in_map,
                   const Trajectory& smoothed, Trajectory* trajectory,
                   std::map<int, Eigen::Isometry3d>* world_from_keyframe,
                   TrackingFigures* figures) {
  std::vector<size_t> kept_index;
  std::vector<RefinedKeyframe> keyframes =
      MapKeyframes(segments, fuser, run_start_times, smoothed, *world_from_keyframe, &kept_index);
  std::map<int, double> times;
  std::map<int, Eigen::Isometry3d> before;
  for (const RefinedKeyframe& keyframe : keyframes) {
    times[keyframe.id] = keyframe.time;
    before[keyframe.id] = keyframe.world_from_camera;
  }
  figures->dense_refinement = RefineKeyframePoses(
      camera,
      [&fuser, &kept_index](size_t index, cv::Mat* gray, cv::Mat* depth_m) {
        fuser.ImagesOf(kept_index[index], gray, depth_m);
      },
      options, &keyframes, parallel);
  const DenseRefinementFigures& refined = *figures->dense_refinement;
  if (refined.next_taken + refined.revisit_taken == 0) return;  // nothing confirmed: as they were
  for (const RefinedKeyframe& keyframe : keyframes) {
    (*world_from_keyframe)[keyframe.id] = keyframe.world_from_camera;
  }
  // A new segment's frames were tracked on a chain of their own, until the segment was joined;
  // after a relocalization the frames are tracked against the map, older keyframes included.
  std::vector<double> segment_starts;
  for (const SegmentSummary& segment : segments.Summaries()) {
    segment_starts.push_back(segment.first_time);
  }
  CarryCorrections(before, *world_from_keyframe, times, in_map, segment_starts,
                   options.frame_smoothing_s, options.max_next_gap_s, trajectory);
}

// final_poses.smoothing_s: each frame's pose fitted to the frames around it in its run. A run
// begins at a frame that began tracking anew (`run_start_times`) and where frames of the map give
// way to those of a segment apart or back.
void Smooth(const TrajectorySmoothingOptions& options, const std::vector<double>& run_start_times,
            const std::vector<bool>& in_map, Trajectory* trajectory, TrackingFigures* figures) {
  std::vector<StampedPose> poses = trajectory->poses();
  std::vector<bool> run_start(poses.size(), false);
  for (size_t i = 0; i < poses.size(); ++i) {
    run_start[i] =
        (i > 0 && in_map[i] != in_map[i - 1]) ||
        std::binary_search(run_start_times.begin(), run_start_times.end(), poses[i].time);
  }
  figures->smoothing = SmoothTrajectory(options, run_start, &poses);
  *trajectory = Trajectory(std::move(poses));
}

// What the user is told about tracking.planar_motion=on: that it was refused, or that the camera
// seems hand-held; nothing when it went as it should, or in "auto", which applies it only where
// it fits.
std::optional<std::string> PlanarMotionWarning(const TrackingFigures& figures,
                                               const TrackerOptions& options) {
  if (options.planar_motion != PlanarMotionMode::kOn) return std::nullopt;
  const std::string key = OptionKey(options, options.planar_motion);
  if (figures.planar_motion_refused) {
    return fmt::format(
        "{}: the camera turned too little to show which way is up (its headings spread less "
        "than {:g}); the poses are left as tracked",
        key, kMinPlanarHeadingSpread);
  }
  const std::optional<PlanarMotion>& plane = figures.planar_motion;
  if (plane && !KeptToPlane(*plane)) {
    return fmt::format(
        "{}: the tracked camera rose and fell by {:.0f} mm and tilted by {:.1f} degrees (median "
        "deviations), more than a robot's does: if the camera was hand-held, build with {}=auto "
        "or off",
        key, plane->height_median_deviation_m * 1e3, plane->tilt_median_deviation_deg, key);
  }
  return std::nullopt;
}

// A frame posed anew, not from the frame before: the smoothing's runs begin there.
bool BeginsRun(TrackStatus status) {
  return status == TrackStatus::kInitialized || status == TrackStatus::kRelocalized ||
         status == TrackStatus::kNewMap;
}

// The final poses of the keyframes and frames: put on the plane of motion
// (tracking.planar_motion), refined densely (final_poses.dense_enabled) and put on the plane
// again, then the frames smoothed. The plane comes first too, so that the refinement judges
// the alignments against level poses: floor seed 1's first and second pass along its east
// corridor were 3-4.5 degrees apart in tilt as tracked, and their revisits all refused.
void SettlePoses(const Camera& camera, const LoopOptions& options,
                 const std::vector<double>& run_start_times, const SegmentKeeper& segments,
                 const KeyframeFuser& fuser, Trajectory* trajectory,
                 std::map<int, Eigen::Isometry3d>* final_poses, TrackingFigures* figures,
                 std::vector<std::string>* warnings) {
  // The frames of the map's segments: the steps below move poses, never frames or segments.
  const std::vector<bool> in_map = segments.FramesInMap(*trajectory);
  if (options.tracking.planar_motion != PlanarMotionMode::kOff) {
    PutOnPlane(camera, options.tracking, fuser, segments, in_map, trajectory, final_poses, figures);
    if (std::optional<std::string> warning = PlanarMotionWarning(*figures, options.tracking)) {
      warnings->push_back(std::move(*warning));
    }
  }
  if (options.refinement.enabled) {
    Trajectory smoothed = *trajectory;
    TrackingFigures unused;
    Smooth(options.smoothing, run_start_times, in_map, &smoothed, &unused);
    RefineDensely(camera, options.refinement, options.parallel, run_start_times, segments, fuser,
                  in_map, smoothed, trajectory, final_poses, figures);
    if (figures->planar_motion_applied) {  // the alignments may have tilted it a little
      SegmentsOntoPlane(*figures->planar_motion, segments, in_map, trajectory, final_poses);
    }
  }
  Smooth(options.smoothing, run_start_times, in_map, trajectory, figures);
}

}  // namespace

PosedFrames RunTrackedLoop(const BuildInputs& inputs, const LoopOptions& options, LoopStages stages,
                           LoopResult* result) {
  std::optional<Tracker> tracker_held;  // freed before the final refusion
  Tracker& tracker = tracker_held.emplace(inputs.camera, options.tracking);
  KeyframeFuser fuser(inputs.camera, options.fuser, stages.masks, &stages.mapper);
  MapSegmentOptions segment_options = options.segments;
  segment_options.fx = inputs.camera.fx;
  SegmentKeeper segments(segment_options);
  auto fuse_final = [&tracker, &fuser, &segments] {
    std::vector<FinalKeyframe> finals = tracker.TakeFinalKeyframes();
    if (!finals.empty()) segments.Fuse(std::move(finals), tracker, fuser);
  };
  TrackingFigures figures;
  size_t corrections = 0;
  std::vector<double> run_start_times;  // frames that began tracking anew, in time order
  for (size_t k = 0; k < stages.reader.size(); ++k) {
    PreparedFrame prepared = stages.reader.Get(k);
    Frame& frame = prepared.frame;
    const double time = frame.time;
    if (!inputs.prior_poses.empty()) tracker.SetPrior(inputs.prior_poses[k]);
    const cv::Mat mask = stages.masks.Compute(
        frame, prepared.gray, prepared.flow ? &*prepared.flow : nullptr, tracker.PredictedPose());
    const TrackResult tracked =
        tracker.Track(frame.index, frame.time, prepared.gray, frame.depth_m, mask);
    Record(tracked, frame.time, &figures);
    if (BeginsRun(tracked.status)) run_start_times.push_back(frame.time);
    segments.Frame(tracked, frame.time);
    if (tracked.status == TrackStatus::kNewMap) fuser.NoteNewSegment();
    if (tracker.pose_corrections() != corrections) {  // the depth check's references moved too
      corrections = tracker.pose_corrections();
      const std::map<int, Eigen::Isometry3d> poses = tracker.KeyframePoses();
      stages.masks.Repose(poses);
      segments.Repose(poses);
      fuser.NoteCorrections(poses);
    }
    if (tracked.keyframe_id >= 0) {
      // What the new keyframe finds moving in earlier ones was a person left unmasked there:
      // the landmarks they made on it go.
      for (const FoundMoving& found :
           stages.masks.AddReference(frame, mask, tracked.world_from_camera, tracked.keyframe_id)) {
        tracker.ForgetLandmarksFoundMoving(found.keyframe_id, found.moving);
      }
      fuser.Hold(tracked.keyframe_id, std::move(frame), mask, tracked.world_from_camera);
    }
    fuse_final();
    if (k % kMemorySampleFrames == 0) {
      SampleLoopMemory(stages, time, TrackedOwners(tracker, fuser, segments));
    }
    stages.progress.Update(k + 1);
  }
  stages.memory.Phase("frame loop's end: the tracker's last loop corrections and adjustment");
  tracker.Finish();
  fuse_final();
  // Loops between segments taken since their group last settled (a settle waits for several)
  // settle it now, before the map is fused again at the final poses.
  segments.SettleLastLoops(tracker);
  // What only frames and keyframes to come would need is freed before the map is fused again.
  segments.EndKeyframes();
  fuser.EndKeyframes();
  stages.masks.EndFrames();
  stages.memory.DropFixed(kDetectorMemoryOwner);
  // What is left to take from the tracker, before it is freed: the final refusion does not carry
  // its place index, keyframes and landmarks (floor seed 1: report peak 1225 -> 1188 MiB).
  std::map<int, Eigen::Isometry3d> final_poses = tracker.KeyframePoses();
  Trajectory trajectory = tracker.TrackedTrajectory();
  figures.statistics = tracker.statistics();
  tracker_held.reset();
  ReleaseFreedMemory();
  if (options.refinement.enabled) {
    stages.memory.Phase("frame loop's end: the keyframes' poses refined densely");
  }
  SettlePoses(inputs.camera, options, run_start_times, segments, fuser, &trajectory, &final_poses,
              &figures, &result->warnings);
  // Loop corrections moved keyframes fused earlier: the map is fused again at the final poses.
  stages.memory.Phase("frame loop's end: fusing moved keyframes again");
  const size_t moved = fuser.Refuse(final_poses);
  const double store_mib = static_cast<double>(fuser.parked_bytes()) / (1024.0 * 1024.0);
  result->apart = segments.TakeApart(fuser, &trajectory);
  result->segments = segments.Summaries();
  result->segment_links = segments.segments().figures();
  CountLostAgain(TakeLostAgain(&result->apart), result, &figures);
  PosedFrames posed{std::move(trajectory), fuser.fused_poses(), fuser.TakeSessionKeyframes(),
                    fuser.depth_unit_m()};
  if (posed.trajectory.empty()) {
    throw std::runtime_error(fmt::format(
        "no frame could be tracked (too few ORB features with depth: is the depth scale right? "
        "see {})",
        OptionKey(&CameraOverrides::depth_factor)));
  }
  figures.prior = !inputs.prior_poses.empty();
  figures.fuse_ms = fuser.fuse_ms();
  figures.refuse_ms = fuser.refuse_ms();
  figures.refused_keyframes_moved = moved;
  figures.refusion_store_mib = store_mib;
  figures.bundle_adjustment_thread = options.tracking.local_map.background_bundle_adjustment;
  result->tracking = std::move(figures);
  result->selection = fuser.figures();
  return posed;
}

}  // namespace stillmap
