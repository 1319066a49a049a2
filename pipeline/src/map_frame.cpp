#include "map_frame.h"

#include <fmt/format.h>

#include <stdexcept>

#include "stillmap/io/option_names.h"

namespace stillmap {
namespace {

bool FloorFound(const FloorPlane& floor) {
  return floor.source == "fitted" || floor.source.rfind("given", 0) == 0;
}

std::string FloorDescription(const FloorPlane& floor) {
  const std::string axes =
      "the origin on the floor under the first camera, x along its viewing direction projected "
      "on the floor, y to its left (REP-103, metres)";
  if (FloorFound(floor)) return "floor: z up, the floor plane at z = 0, " + axes;
  return "floor: no floor plane was found, so z is the cameras' mean up (gravity assumed) and "
         "z = 0 the 2nd percentile of the map's heights; " +
         axes;
}

// `world_from_camera_at(time)`'s world in the frame of `posed`, anchored at the first posed
// frame that has a pose there.
template <typename Lookup>
std::optional<Eigen::Isometry3d> AnchorOf(const PosedFrames& posed, Lookup&& world_from_camera_at) {
  for (const StampedPose& tracked : posed.trajectory.poses()) {
    const std::optional<Eigen::Isometry3d> world_from_camera = world_from_camera_at(tracked.time);
    if (world_from_camera) return *world_from_camera * tracked.world_from_camera.inverse();
  }
  return std::nullopt;
}

// The given poses' world in the frame of `posed` (identity when they are the poses).
std::optional<Eigen::Isometry3d> GivenFromPoses(const BuildInputs& inputs,
                                                const MapFrameChoice& choice,
                                                const PosedFrames& posed) {
  if (choice.poses == PoseSource::kGiven) return Eigen::Isometry3d::Identity();
  if (!inputs.given) return std::nullopt;
  return AnchorOf(posed, [&](double time) { return inputs.given->At(time, nullptr); });
}

}  // namespace

std::optional<Eigen::Isometry3d> GroundTruthFromPoses(const BuildInputs& inputs, double max_gap_s,
                                                      const PosedFrames& posed) {
  if (!inputs.sequence.groundtruth()) return std::nullopt;
  // The first tracked frame with a ground-truth pose (the motion capture may start late).
  return AnchorOf(posed, [&](double time) {
    return inputs.sequence.groundtruth()->Interpolate(time, max_gap_s);
  });
}

MapFrameFigures ChooseMapFrame(const FloorPlane& floor, const BuildInputs& inputs,
                               const MapFrameChoice& choice, const PosedFrames& posed) {
  MapFrameFigures frame;
  frame.name = choice.frame;
  frame.floor = floor;
  frame.floor_found = FloorFound(floor);
  const Eigen::Isometry3d first_camera = posed.trajectory.poses().front().world_from_camera;
  const Eigen::Isometry3d poses_from_floor =
      FloorFrame(floor, first_camera.translation(), first_camera.linear().col(2));
  if (frame.name == "floor") {
    frame.poses_from_map = poses_from_floor;
    frame.description = FloorDescription(floor);
  } else if (frame.name == "camera") {
    frame.poses_from_map = first_camera;
    frame.description = "camera: the first camera's optical frame (x right, y down, z forward)";
  } else if (frame.name == "poses") {
    const std::optional<Eigen::Isometry3d> given_from_poses = GivenFromPoses(inputs, choice, posed);
    if (!given_from_poses) {
      throw std::runtime_error(
          fmt::format("{}=poses: no tracked frame has a given pose to anchor the map; use {}=floor",
                      OptionKey(&MapFrameOptions::frame), OptionKey(&MapFrameOptions::frame)));
    }
    frame.poses_from_map = given_from_poses->inverse();
    frame.description = fmt::format(
        "poses: the given poses' world frame ({}){}", inputs.given->world_frame(),
        choice.poses == PoseSource::kGiven ? ""
                                           : ", the tracked map anchored at the given pose of the "
                                             "first tracked frame that has one");
  } else {
    const std::optional<Eigen::Isometry3d> groundtruth_from_poses =
        choice.poses == PoseSource::kGroundTruth
            ? std::optional<Eigen::Isometry3d>(Eigen::Isometry3d::Identity())
            : GroundTruthFromPoses(inputs, choice.max_groundtruth_gap_s, posed);
    if (!groundtruth_from_poses) {
      throw std::runtime_error(
          fmt::format("{}=groundtruth: no tracked frame has a ground-truth pose to anchor the map; "
                      "use {}=floor",
                      OptionKey(&MapFrameOptions::frame), OptionKey(&MapFrameOptions::frame)));
    }
    frame.poses_from_map = groundtruth_from_poses->inverse();
    frame.description =
        choice.poses == PoseSource::kGroundTruth
            ? "groundtruth: the ground truth's world frame (groundtruth.txt)"
            : "groundtruth: the ground truth's world frame (groundtruth.txt), the tracked map "
              "anchored at the ground-truth pose of the first tracked frame that has one";
  }
  frame.map_from_floor = frame.poses_from_map.inverse() * poses_from_floor;
  return frame;
}

PosedFrames PosesInMap(const PosedFrames& posed, const Eigen::Isometry3d& map_from_poses) {
  auto moved = [&](std::vector<StampedPose> poses) {
    for (StampedPose& pose : poses)
      pose.world_from_camera = map_from_poses * pose.world_from_camera;
    return poses;
  };
  return {Trajectory(moved(posed.trajectory.poses())), moved(posed.fused_poses), {}, 0.0};
}

}  // namespace stillmap
