#include "given_session.h"
#include "pose_loops.h"

namespace stillmap {

KnownPosePlan PlanKnownPoseFrames(const BuildInputs& inputs, const LoopOptions& options) {
  const auto reference_every = static_cast<size_t>(options.groundtruth_reference_interval);
  const bool every_frame = options.FusesEveryFrame();
  const size_t n = inputs.known_poses.size();
  KnownPosePlan plan{{}, std::vector<bool>(n, false), std::vector<bool>(n, false)};
  const Eigen::Isometry3d* last_fused = nullptr;
  for (size_t k = 0; k < n; ++k) {
    const Eigen::Isometry3d& pose = inputs.known_poses[k].world_from_camera;
    plan.fuse[k] =
        every_frame || last_fused == nullptr ||
        MovedOrTurned(*last_fused, pose, options.keyframe_distance_m, options.keyframe_angle_deg);
    if (plan.fuse[k]) last_fused = &pose;
    plan.reference[k] = k % reference_every == 0;
    if (plan.fuse[k] || plan.reference[k]) plan.read.push_back(k);
  }
  return plan;
}

PosedFrames RunGroundTruthLoop(const BuildInputs& inputs, const LoopOptions& options,
                               const KnownPosePlan& plan, LoopStages stages) {
  std::vector<StampedPose> fused;
  std::optional<GivenSessionKeeper> session;
  if (options.given_session) {
    session.emplace(inputs.camera, options.tracking.features, options.fuser.max_depth_m);
  }
  for (size_t j = 0; j < plan.read.size(); ++j) {
    const PreparedFrame prepared = stages.reader.Get(j);
    const size_t k = plan.read[j];
    stages.progress.Update(k + 1);
    const bool fuse = plan.fuse[k], reference = plan.reference[k];
    const Frame& frame = prepared.frame;
    const Eigen::Isometry3d& pose = inputs.known_poses[k].world_from_camera;
    const cv::Mat mask =
        stages.masks.Compute(frame, prepared.gray, prepared.flow ? &*prepared.flow : nullptr, pose);
    if (reference) stages.masks.AddReference(frame, mask, pose, -1);
    if (j % kMemorySampleFrames == 0) SampleLoopMemory(stages, frame.time);
    if (fuse) {
      stages.mapper.Integrate(
          {frame.time, frame.color, frame.depth_m, mask, pose, false, cv::Mat()});
      fused.push_back(inputs.known_poses[k]);
      if (session) session->Offer(frame, prepared.gray, mask, pose);
    }
  }
  stages.progress.Update(inputs.known_poses.size());
  if (!session) return {Trajectory(inputs.known_poses), std::move(fused), {}, 0.0};
  return {Trajectory(inputs.known_poses), std::move(fused), session->Take(),
          session->depth_unit_m()};
}

}  // namespace stillmap
