#include "report_poses.h"

#include <fmt/format.h>

#include "report_parts.h"

namespace stillmap {

using json = nlohmann::json;

const char* PoseSourceName(PoseSource poses) {
  switch (poses) {
    case PoseSource::kTracking:
      return "tracking";
    case PoseSource::kGroundTruth:
      return "groundtruth";
    case PoseSource::kGiven:
      return "given";
  }
  return "";
}

// How the map was put in the ground truth's frame for its quality figures.
const char* AlignedBy(PoseSource poses) {
  switch (poses) {
    case PoseSource::kTracking:
      return "the rigid transform that best carries the tracked poses onto their ground-truth "
             "poses (rotation: the chordal mean over every frame with one; then the mean "
             "position offset)";
    case PoseSource::kGroundTruth:
      return "nothing: the poses are the ground truth";
    case PoseSource::kGiven:
      return "the rigid transform that best carries the given poses onto their ground-truth "
             "poses (rotation: the chordal mean over every frame with one; then the mean "
             "position offset)";
  }
  return "";
}

namespace {

const char* PosesFrame(PoseSource poses) {
  switch (poses) {
    case PoseSource::kTracking:
      return "the first tracked camera's frame";
    case PoseSource::kGroundTruth:
      return "the ground truth's world frame";
    case PoseSource::kGiven:
      return "the given poses' world frame";
  }
  return "";
}

}  // namespace

json MapFrameJson(const MapFrameFigures& frame, PoseSource poses) {
  return {{"name", frame.name},
          {"description", frame.description},
          {"files", "map.ply, map.pcd, map.bt, map.ot, the mesh, trajectory.txt, keyframes.txt"},
          {"floor_found", frame.floor_found},
          {"floor", FloorJson(frame.floor)},
          {"poses_frame", PosesFrame(poses)},
          {"poses_from_map", RowMajor(frame.poses_from_map)}};
}

json GivenPosesJson(const GivenPoseFigures& given) {
  return {{"source", given.source},
          {"use", given.use},
          {"from", given.description},
          {"world_frame", given.world_frame},
          {"frames_without_pose",
           {{"before_the_poses", given.before},
            {"before_by_up_to_s", given.before_s},
            {"after_the_poses", given.after},
            {"after_by_up_to_s", given.after_s},
            {"across_gaps", given.in_gaps}}}};
}

nlohmann::json SegmentsJson(const std::vector<SegmentSummary>& segments) {
  nlohmann::json out = nlohmann::json::array();
  for (const SegmentSummary& s : segments) {
    nlohmann::json entry = {
        {"id", s.id},
        {"first_time", s.first_time},
        {"last_time", s.last_time},
        {"frames", s.frames},
        {"keyframes", s.keyframes},
        {"joined", SegmentJoinName(s.join)},
        {"in", s.in_map ? std::string("map") : fmt::format("segments/{}/", s.id)}};
    if (s.join == SegmentJoin::kLinked) {
      entry["joined_to"] = s.joined_to;
      entry["joined_at_time"] = s.joined_time;
      entry["agreeing_links"] = s.links;
    }
    out.push_back(entry);
  }
  return out;
}

}  // namespace stillmap
