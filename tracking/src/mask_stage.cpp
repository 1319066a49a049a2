#include "stillmap/tracking/mask_stage.h"

#include <chrono>

#include "stillmap/io/timing.h"

namespace stillmap {

MaskStage::MaskStage(const Camera& camera, const DynamicMaskOptions& options, bool enabled,
                     std::unique_ptr<Detector> detector, const std::string& sequence_dir)
    : enabled_(enabled), options_(options), truth_(sequence_dir) {
  if (!enabled_) return;
  detector_ = std::move(detector);
  masker_ = std::make_unique<DynamicMasker>(camera, options_);
}

cv::Mat MaskStage::Compute(const Frame& frame, const cv::Mat& gray, const FlowStep* flow,
                           const std::optional<Eigen::Isometry3d>& world_from_camera) {
  if (!enabled_) return cv::Mat();
  MaskingStatistics& s = statistics_;
  std::vector<Detection> detections;
  const bool detect = detector_ != nullptr && options_.semantics &&
                      s.frames % static_cast<size_t>(options_.detector_interval) == 0;
  if (detect) {
    const auto start = std::chrono::steady_clock::now();
    detections = detector_->Detect(frame.color);
    s.detector_ms.push_back(MillisecondsSince(start));
    for (const Detection& detection : detections) {
      ++s.detections_by_level[MotionLevelName(detection.level)];
    }
  }
  const DynamicMaskResult result = masker_->Compute(gray, frame.depth_m, world_from_camera,
                                                    detect ? &detections : nullptr, flow);
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
