#include "given_session.h"
#include "pose_loops.h"

namespace stillmap {

PosedFrames RunGroundTruthLoop(const BuildInputs& inputs, const LoopOptions& options,
                               LoopStages stages) {
  const auto reference_every = static_cast<size_t>(options.groundtruth_reference_interval);
  const bool every_frame = options.keyframe_distance_m <= 0.0 && options.keyframe_angle_deg <= 0.0;
  std::vector<StampedPose> fused;
  std::optional<GivenSessionKeeper> session;
  if (options.given_session) {
    session.emplace(inputs.camera, options.tracking.features, options.fuser.max_depth_m);
  }
  for (size_t k = 0; k < stages.reader.size(); ++k) {
    const PreparedFrame prepared = stages.reader.Get(k);
    const Frame& frame = prepared.frame;
    const Eigen::Isometry3d& pose = inputs.known_poses[k].world_from_camera;
    const bool fuse = every_frame || fused.empty() ||
                      MovedOrTurned(fused.back().world_from_camera, pose,
                                    options.keyframe_distance_m, options.keyframe_angle_deg);
    const bool reference = k % reference_every == 0;
    if (fuse || reference) {  // a frame neither fused nor a reference is not masked
      const cv::Mat mask = stages.masks.Compute(frame, prepared.gray,
                                                prepared.flow ? &*prepared.flow : nullptr, pose);
      if (reference) stages.masks.AddReference(frame, mask, pose, -1);
      if (fuse) {
        stages.mapper.Integrate({frame.time, frame.color, frame.depth_m, mask, pose});
        fused.push_back(inputs.known_poses[k]);
        if (session) session->Offer(frame, prepared.gray, mask, pose);
      }
    }
    stages.progress.Update(k + 1);
  }
  if (!session) return {Trajectory(inputs.known_poses), std::move(fused), {}, 0.0};
  return {Trajectory(inputs.known_poses), std::move(fused), session->Take(),
          session->depth_unit_m()};
}

}  // namespace stillmap
