#include "keyframe_fuser.h"

#include <chrono>

#include "stillmap/io/timing.h"

namespace stillmap {

KeyframeFuser::KeyframeFuser(const Camera& camera, const BuildConfig& config,
                             const MaskStage& masks, Mapper* mapper)
    : mapper_(*mapper), selector_(config.selection), factors_(camera) {
  if (masks.enabled() && config.map_recheck && config.masking.depth_check) {
    recheck_.emplace(masks.masker()->geometry(), config.masking);
  }
}

void KeyframeFuser::Hold(int keyframe_id, Frame frame, const cv::Mat& mask,
                         const Eigen::Isometry3d& world_from_camera) {
  MaskReference reference{frame.time, frame.depth_m, mask, world_from_camera, cv::Mat()};
  waiting_.emplace(keyframe_id, Waiting{std::move(frame), std::move(reference)});
}

cv::Mat KeyframeFuser::Recheck(const FinalKeyframe& keyframe, std::map<int, Waiting>::iterator it,
                               bool* changed) {
  std::vector<MaskReference*> later;
  for (auto next = std::next(it); next != waiting_.end(); ++next) {
    later.push_back(&next->second.reference);
  }
  const Waiting& waiting = it->second;
  return recheck_->Recheck(keyframe.time, waiting.frame.depth_m, keyframe.world_from_camera,
                           waiting.reference.mask, later, changed);
}

void KeyframeFuser::Fuse(const std::vector<FinalKeyframe>& finals,
                         const DepthCorrection& correction) {
  const auto start = std::chrono::steady_clock::now();
  for (const FinalKeyframe& keyframe : finals) {
    const auto it = waiting_.find(keyframe.id);
    if (it == waiting_.end()) continue;
    const Frame& frame = it->second.frame;
    bool changed = false;
    const cv::Mat mask = recheck_ ? Recheck(keyframe, it, &changed) : it->second.reference.mask;
    recheck_additions_ += changed ? 1 : 0;
    const double share = mask.empty() ? 0.0
                                      : static_cast<double>(cv::countNonZero(mask)) /
                                            static_cast<double>(mask.total());
    if (selector_.Judge(share, keyframe.landmarks) == KeyframeVerdict::kFused) {
      MapperFrame input{frame.time, frame.color, frame.depth_m, mask, keyframe.world_from_camera};
      // The depth corrected as the tracker's self-calibration has it now (the poses are
      // consistent with it).
      if (!correction.IsIdentity()) input.depth_m = frame.depth_m.mul(factors_.For(correction));
      mapper_.Integrate(input);
      fused_poses_.push_back({keyframe.time, keyframe.world_from_camera});
    }
    if (recheck_) {
      MaskReference done = std::move(it->second.reference);
      done.mask = mask;
      done.world_from_camera = keyframe.world_from_camera;  // final
      recheck_->Remember(std::move(done), changed);
    }
    waiting_.erase(it);
  }
  fuse_ms_ += MillisecondsSince(start);
}

SelectionFigures KeyframeFuser::figures() const {
  return {selector_.invalid(), selector_.redundant(), recheck_additions_};
}

}  // namespace stillmap
