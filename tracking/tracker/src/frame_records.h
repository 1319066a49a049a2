// What the tracker keeps of each posed frame, and of the motion model's run through an occlusion.
#pragma once

#include <Eigen/Geometry>
#include <cstddef>

namespace stillmap {

// The motion model's run through an occlusion: its frames' records and the last good pose before.
struct PredictionRun {
  size_t begin = 0, end = 0;
  Eigen::Isometry3d last_good_camera_from_world = Eigen::Isometry3d::Identity();
  double last_good_time = 0.0;
};

// A tracked frame, relative to its reference keyframe so that keyframe corrections carry over.
struct FrameRecord {
  double time = 0.0;
  int reference_keyframe = 0;
  Eigen::Isometry3d camera_from_reference = Eigen::Isometry3d::Identity();
};

}  // namespace stillmap
