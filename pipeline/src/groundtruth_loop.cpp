#include "pose_loops.h"

namespace stillmap {

PosedFrames RunGroundTruthLoop(const BuildInputs& inputs, int reference_interval,
                               LoopStages stages) {
  const auto reference_every = static_cast<size_t>(reference_interval);
  for (size_t k = 0; k < stages.reader.size(); ++k) {
    const PreparedFrame prepared = stages.reader.Get(k);
    const Frame& frame = prepared.frame;
    const Eigen::Isometry3d& pose = inputs.known_poses[k].world_from_camera;
    const cv::Mat mask =
        stages.masks.Compute(frame, prepared.gray, prepared.flow ? &*prepared.flow : nullptr, pose);
    if (k % reference_every == 0) stages.masks.AddReference(frame, mask, pose, -1);
    stages.mapper.Integrate({frame.time, frame.color, frame.depth_m, mask, pose});
    stages.progress.Update(k + 1);
  }
  return {Trajectory(inputs.known_poses), inputs.known_poses, {}, 0.0};
}

}  // namespace stillmap
