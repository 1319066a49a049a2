#include "pose_loops.h"

namespace stillmap {

PosedFrames RunGroundTruthLoop(const BuildInputs& inputs, LoopStages stages) {
  // References for the depth check every fifth frame: 6 per second at 30 Hz, enough for its
  // spacing (masking.reference_spacing_s) without a reference per frame.
  constexpr size_t kReferenceEvery = 5;
  for (size_t k = 0; k < stages.reader.size(); ++k) {
    const PreparedFrame prepared = stages.reader.Get(k);
    const Frame& frame = prepared.frame;
    const Eigen::Isometry3d& pose = inputs.groundtruth_poses[k].world_from_camera;
    const cv::Mat mask =
        stages.masks.Compute(frame, prepared.gray, prepared.flow ? &*prepared.flow : nullptr, pose);
    if (k % kReferenceEvery == 0) stages.masks.AddReference(frame, mask, pose);
    stages.mapper.Integrate({frame.time, frame.color, frame.depth_m, mask, pose});
    stages.progress.Update(k + 1);
  }
  return {Trajectory(inputs.groundtruth_poses), inputs.groundtruth_poses};
}

}  // namespace stillmap
