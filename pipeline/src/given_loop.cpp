#include <deque>
#include <limits>

#include "given_session.h"
#include "keyframe_fuser.h"
#include "pose_loops.h"

namespace stillmap {

PosedFrames RunGivenPoseLoop(const BuildInputs& inputs, const LoopOptions& options,
                             const KnownPosePlan& plan, LoopStages stages, LoopResult* result) {
  FuserOptions fuser_options = options.fuser;
  fuser_options.keep_for_refusion = false;  // given poses never move
  fuser_options.keep_for_session = false;   // the session keeper keeps its own keyframes
  KeyframeFuser fuser(inputs.camera, fuser_options, stages.masks, &stages.mapper);
  std::optional<GivenSessionKeeper> session;
  if (options.given_session) {
    session.emplace(inputs.camera, options.tracking.features, options.fuser.max_depth_m);
  }
  // A keyframe is final once keyframes as far after it as the depth check looks back have come:
  // its mask is re-checked against them, as a tracked keyframe's is on leaving the window.
  const double horizon_s = stages.masks.options().ReferenceHorizonS();
  std::deque<FinalKeyframe> held;
  int next_id = 0;
  auto fuse_before = [&held, &fuser](double time) {
    std::vector<FinalKeyframe> finals;
    while (!held.empty() && held.front().time < time) {
      finals.push_back(std::move(held.front()));
      held.pop_front();
    }
    if (!finals.empty()) fuser.Fuse(finals, DepthCorrection());
  };
  for (size_t j = 0; j < plan.read.size(); ++j) {
    PreparedFrame prepared = stages.reader.Get(j);
    const size_t k = plan.read[j];
    stages.progress.Update(k + 1);
    Frame& frame = prepared.frame;
    const Eigen::Isometry3d& pose = inputs.known_poses[k].world_from_camera;
    const cv::Mat mask =
        stages.masks.Compute(frame, prepared.gray, prepared.flow ? &*prepared.flow : nullptr, pose);
    if (plan.reference[k]) stages.masks.AddReference(frame, mask, pose, -1);
    if (j % kMemorySampleFrames == 0) {
      SampleLoopMemory(
          stages, frame.time,
          {{"keyframes_held", fuser.held_bytes()}, {"keyframe_copies", fuser.stored_bytes()}});
    }
    if (!plan.fuse[k]) continue;
    if (session) session->Offer(frame, prepared.gray, mask, pose);
    FinalKeyframe keyframe;
    keyframe.id = next_id++;  // consecutive, as the tracker's (the revisit rule counts them)
    keyframe.frame_index = frame.index;
    keyframe.time = frame.time;
    keyframe.world_from_camera = pose;
    fuser.Hold(keyframe.id, std::move(frame), mask, pose);
    held.push_back(std::move(keyframe));
    fuse_before(held.back().time - horizon_s);
  }
  fuse_before(std::numeric_limits<double>::infinity());
  stages.progress.Update(inputs.known_poses.size());
  result->selection = fuser.figures();
  PosedFrames posed{Trajectory(inputs.known_poses), fuser.fused_poses(), {}, 0.0};
  if (session) {
    posed.session_keyframes = session->Take();
    posed.session_depth_unit_m = session->depth_unit_m();
  }
  return posed;
}

}  // namespace stillmap
