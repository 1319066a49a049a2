#include "segment_keeper.h"

namespace stillmap {

std::vector<ApartSegment> TakeLostAgain(std::vector<ApartSegment>* apart) {
  std::vector<ApartSegment> lost_again, kept;
  for (ApartSegment& segment : *apart) {
    (segment.keyframes.empty() ? lost_again : kept).push_back(std::move(segment));
  }
  *apart = std::move(kept);
  return lost_again;
}

void SegmentKeeper::Frame(const TrackResult& tracked, double time) {
  if (tracked.status == TrackStatus::kInitialized || tracked.status == TrackStatus::kNewMap) {
    segments_.Begin(tracked.keyframe_id, time);
  }
  if (tracked.tracked()) segments_.AddFrame(time);
}

void SegmentKeeper::Fuse(std::vector<FinalKeyframe> finals, Tracker& tracker,
                         KeyframeFuser& fuser) {
  bool joined = false;
  for (const FinalKeyframe& keyframe : finals) {
    if (keyframe.culled) continue;
    const std::optional<SegmentCorrection> correction =
        segments_.AddKeyframe(keyframe.id, keyframe.time, keyframe.world_from_camera,
                              SessionFeatures(keyframe.features), keyframe.weakest_inliers);
    if (!correction) continue;
    tracker.MoveKeyframes(correction->world_from_keyframe);
    joined = true;
  }
  std::map<int, Eigen::Isometry3d> poses;
  if (joined) {  // the keyframes are fused where the join put them
    poses = tracker.KeyframePoses();
    for (FinalKeyframe& keyframe : finals) {
      const auto it = poses.find(keyframe.id);
      if (it != poses.end()) keyframe.world_from_camera = it->second;
    }
    segments_.Repose(poses);
  }
  const auto in_map = [this](int id) { return segments_.InMap(segments_.SegmentOf(id)); };
  fuser.Fuse(finals, tracker.depth_correction(), in_map,
             [this](int id) { return segments_.SegmentOf(id); });
  if (joined) fuser.FuseJoined(in_map, poses);
}

int SegmentKeeper::SegmentAt(double time, const std::vector<SegmentSummary>& summaries) const {
  int segment = 0;
  for (const SegmentSummary& summary : summaries) {
    if (summary.first_time <= time) segment = summary.id;
  }
  return segment;
}

std::vector<bool> SegmentKeeper::FramesInMap(const Trajectory& all) const {
  const std::vector<SegmentSummary> summaries = segments_.Summaries();
  std::vector<bool> in_map;
  in_map.reserve(all.size());
  for (const StampedPose& pose : all.poses()) {
    in_map.push_back(summaries.empty() ||
                     summaries[static_cast<size_t>(SegmentAt(pose.time, summaries))].in_map);
  }
  return in_map;
}

std::vector<ApartSegment> SegmentKeeper::TakeApart(KeyframeFuser& fuser, Trajectory* all) const {
  const std::vector<SegmentSummary> summaries = segments_.Summaries();
  std::vector<ApartSegment> apart;
  std::vector<int> index_of(summaries.size(), -1);  // segment -> its place in `apart`
  for (const SegmentSummary& summary : summaries) {
    if (summary.in_map) continue;
    index_of[static_cast<size_t>(summary.id)] = static_cast<int>(apart.size());
    ApartSegment segment;
    segment.summary = summary;
    segment.keyframes =
        fuser.TakeApart([this, &summary](int id) { return segments_.SegmentOf(id) == summary.id; });
    apart.push_back(std::move(segment));
  }
  if (apart.empty()) return apart;
  std::vector<StampedPose> kept;
  std::vector<std::vector<StampedPose>> apart_poses(apart.size());
  for (const StampedPose& pose : all->poses()) {
    const int index = index_of[static_cast<size_t>(SegmentAt(pose.time, summaries))];
    if (index < 0) {
      kept.push_back(pose);
    } else {
      apart_poses[static_cast<size_t>(index)].push_back(pose);
    }
  }
  *all = Trajectory(std::move(kept));
  for (size_t k = 0; k < apart.size(); ++k)
    apart[k].trajectory = Trajectory(std::move(apart_poses[k]));
  return apart;
}

}  // namespace stillmap
