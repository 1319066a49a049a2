#include "session_output.h"

#include <filesystem>

namespace stillmap {

void WriteSessionFile(SessionKeyframeList keyframes, double depth_unit_m,
                      const MapFrameFigures& frame, const BuildInputs& inputs,
                      const std::string& sequence, const std::string& path) {
  const Eigen::Isometry3d map_from_poses = frame.poses_from_map.inverse();
  for (size_t k = 0; k < keyframes.size(); ++k) {
    SessionKeyframe& keyframe = keyframes.keyframe(k);
    keyframe.map_from_camera = map_from_poses * keyframe.map_from_camera;
  }
  SessionRecord record;
  record.camera = inputs.camera;
  record.depth_unit_m = depth_unit_m;
  std::error_code error;
  const std::filesystem::path absolute = std::filesystem::absolute(sequence, error);
  record.sequence = error ? sequence : absolute.lexically_normal().string();
  record.stillmap_version = STILLMAP_VERSION;
  if (inputs.given) {
    record.poses = inputs.given->source().text +
                   (inputs.known_poses.empty() ? ", the tracker's prior" : ", the map's poses");
  }
  SessionMapFrame& out = record.map_frame;
  out.name = frame.name;
  out.description = frame.description;
  // height = up . x + offset in the poses' frame, with x = poses_from_map * x_map.
  out.floor_up = map_from_poses.linear() * frame.floor.up;
  out.floor_offset = frame.floor.offset + frame.floor.up.dot(frame.poses_from_map.translation());
  out.floor_found = frame.floor_found;
  out.floor_source = frame.floor.source;
  out.map_from_floor = frame.map_from_floor;
  keyframes.Write(path, record);
}

}  // namespace stillmap
