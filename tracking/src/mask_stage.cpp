#include "stillmap/tracking/mask_stage.h"

namespace stillmap {

MaskStage::MaskStage(const Camera& camera, const DynamicMaskOptions& options, bool enabled,
                     std::unique_ptr<Detector> detector, bool detector_in_background,
                     const std::string& sequence_dir)
    : enabled_(enabled), options_(options), truth_(sequence_dir) {
  if (!enabled_) return;
  if (detector != nullptr && options_.semantics) {
    detections_ = std::make_unique<DetectionSchedule>(
        std::move(detector), options_.detector_interval, detector_in_background);
    statistics_.detector_in_background = detector_in_background;
  }
  masker_ = std::make_unique<DynamicMasker>(camera, options_);
}

cv::Mat MaskStage::Compute(const Frame& frame, const cv::Mat& gray, const FlowStep* flow,
                           const std::optional<Eigen::Isometry3d>& world_from_camera) {
  if (!enabled_) return cv::Mat();
  MaskingStatistics& s = statistics_;
  std::optional<DetectorRun> run;
  if (detections_) {
    run = detections_->Next(frame.color, flow);
    s.detector_wait_ms = detections_->wait_ms();
  }
  if (run) {
    s.detector_ms.push_back(run->ms);
    for (const Detection& detection : run->detections) {
      ++s.detections_by_level[MotionLevelName(detection.level)];
    }
  }
  const DynamicMaskResult result = masker_->Compute(gray, frame.depth_m, world_from_camera,
                                                    run ? &run->detections : nullptr, flow);
  ++s.frames;
  s.mask_ms.push_back(result.ms);
  s.share_sum += result.share;
  s.depth_seeds += static_cast<size_t>(result.depth_seeds);
  s.flow_seeds += static_cast<size_t>(result.flow_seeds);
  s.high_regions += static_cast<size_t>(result.high_regions);
  s.high_confirmed += static_cast<size_t>(result.high_confirmed);
  s.medium_moving += static_cast<size_t>(result.medium_moving);
  s.medium_static += static_cast<size_t>(result.medium_static);
  s.geometric_only += static_cast<size_t>(result.geometric_only_regions);
  s.frames_with_mask += result.share > 0.0 ? 1 : 0;
  if (truth_.available()) {
    const cv::Mat truth = truth_.Get(frame.time);
    if (!truth.empty() && truth.size() == result.mask.size()) score_.Add(result.mask, truth);
  }
  return result.mask;
}

void MaskStage::AddReference(const Frame& frame, const cv::Mat& mask,
                             const Eigen::Isometry3d& world_from_camera) {
  if (!enabled_) return;
  masker_->AddReference({frame.time, frame.depth_m, mask, world_from_camera, cv::Mat()});
}

MaskingStatistics MaskStage::statistics() const {
  MaskingStatistics statistics = statistics_;
  if (score_.frames > 0 || score_.true_positive + score_.false_positive > 0) {
    statistics.score = score_;
  }
  return statistics;
}

}  // namespace stillmap
