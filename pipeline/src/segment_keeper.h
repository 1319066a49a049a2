// Map segments in a tracked build (map_segments.h): where each begins, its frames, and its final
// keyframes as places. A join moves the tracker's keyframes and fuses the keyframes kept apart
// that are now in the map; at the end, each segment never joined is handed out with its frames and
// keyframes, to be written apart.
#pragma once

#include <vector>

#include "keyframe_fuser.h"
#include "stillmap/io/session_record.h"
#include "stillmap/io/trajectory.h"
#include "stillmap/tracking/map_segments.h"
#include "stillmap/tracking/tracker.h"

namespace stillmap {

// A segment never joined to the map: its frames and fused keyframes in its own frame (the
// tracker's world as its new local map began), for a build of its own.
struct ApartSegment {
  SegmentSummary summary;
  Trajectory trajectory;
  SessionKeyframeList keyframes;
};

// Takes out of `apart` the segments none of whose keyframes was kept for a map: begun anew after
// a loss and lost again before they held a map (floor_lost seed 1: 2 frames at 1298.33 s). Nothing
// can be mapped of them and nothing can place them later (a merge links keyframes), so their
// frames are lost frames, not a segment, as ORB-SLAM3 resets a map lost before it has grown.
std::vector<ApartSegment> TakeLostAgain(std::vector<ApartSegment>* apart);

class SegmentKeeper {
 public:
  explicit SegmentKeeper(const MapSegmentOptions& options) : segments_(options) {}

  // A tracked frame: a new segment begins with the first map and each new one after a loss.
  void Frame(const TrackResult& tracked, double time);
  // The keyframes that became final: places of their segments (a join moves the tracker's
  // keyframes), then judged and fused, or kept apart while their segment is not in the map.
  void Fuse(std::vector<FinalKeyframe> finals, Tracker& tracker, KeyframeFuser& fuser);
  // After the last keyframe: the loops taken since the last settle settle their groups, and the
  // tracker's keyframes follow.
  void SettleLastLoops(Tracker& tracker) {
    const std::map<int, Eigen::Isometry3d> moved = segments_.SettleLastLoops();
    if (!moved.empty()) tracker.MoveKeyframes(moved);
  }
  // After the last keyframe (and SettleLastLoops): what only new keyframes need is freed.
  void EndKeyframes() { segments_.EndKeyframes(); }
  // The tracker's keyframes moved (its loops, its global bundle adjustment).
  void Repose(const std::map<int, Eigen::Isometry3d>& world_from_keyframe) {
    segments_.Repose(world_from_keyframe);
  }
  // After the last frame: the trajectory's frames of the map's segments (`all` without those of
  // the segments written apart), and the segments apart.
  std::vector<ApartSegment> TakeApart(KeyframeFuser& fuser, Trajectory* all) const;
  // Per pose of `all`: whether its frame belongs to a segment of the map (by now).
  std::vector<bool> FramesInMap(const Trajectory& all) const;
  bool KeyframeInMap(int keyframe_id) const {
    return segments_.InMap(segments_.SegmentOf(keyframe_id));
  }
  std::vector<SegmentSummary> Summaries() const { return segments_.Summaries(); }
  const MapSegments& segments() const { return segments_; }

 private:
  // The segment a frame at `time` belongs to: the last one begun at or before it.
  int SegmentAt(double time, const std::vector<SegmentSummary>& summaries) const;

  MapSegments segments_;
};

}  // namespace stillmap
