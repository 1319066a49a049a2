// The frame of the 3-D outputs (map.frame), chosen once the map is finished and its floor known.
#pragma once

#include <Eigen/Geometry>
#include <optional>

#include "build_inputs.h"
#include "pose_loops.h"
#include "stillmap/pipeline/build_result.h"

namespace stillmap {

// The ground truth's world frame in the frame of `posed`: the ground-truth pose of the first
// posed frame that has one (the motion capture may start late) times the inverse of its pose.
// Not the ATE
// alignment, whose rotation is ill-determined by positions alone when the camera moves little or
// along a line. Nothing when no posed frame has a ground-truth pose.
// `max_gap_s`: sequence.max_groundtruth_gap.
std::optional<Eigen::Isometry3d> GroundTruthFromPoses(const BuildInputs& inputs, double max_gap_s,
                                                      const PosedFrames& posed);

// What choosing the map frame reads of the request.
struct MapFrameChoice {
  std::string frame = "floor";  // map.frame
  PoseSource poses = PoseSource::kTracking;
  double max_groundtruth_gap_s = 0.0;
};

// The frame choice.frame names, from the floor (in the poses' frame) and the first posed
// camera. Without a fitted or given floor, "floor" stands on the cameras' mean up (gravity) and
// the description says so. Throws std::runtime_error for "groundtruth" when the first frame has
// no ground-truth pose.
MapFrameFigures ChooseMapFrame(const FloorPlane& floor, const BuildInputs& inputs,
                               const MapFrameChoice& choice, const PosedFrames& posed);

// `posed` with every pose moved into the map frame (left-multiplied by map_from_poses).
PosedFrames PosesInMap(const PosedFrames& posed, const Eigen::Isometry3d& map_from_poses);

}  // namespace stillmap
