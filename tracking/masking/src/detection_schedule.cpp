#include "stillmap/tracking/detection_schedule.h"

#include <chrono>

#include "stillmap/io/cpu_usage.h"
#include "stillmap/io/timing.h"
#include "stillmap/tracking/dynamic_mask.h"

namespace stillmap {
namespace {

DetectorRun Run(Detector& detector, const cv::Mat& bgr) {
  const auto start = std::chrono::steady_clock::now();
  const double cpu = ThreadCpuMs();
  DetectorRun run;
  run.detections = detector.Detect(bgr);
  run.ms = MillisecondsSince(start);
  run.cpu_ms = ThreadCpuMs() - cpu;
  return run;
}

}  // namespace

DetectionSchedule::DetectionSchedule(std::unique_ptr<Detector> detector, int interval,
                                     bool background, bool own_thread)
    : detector_(std::move(detector)), interval_(interval), background_(background) {
  CV_Assert(detector_ != nullptr && interval_ >= 1);
  if (background_ && own_thread) worker_ = std::make_unique<SerialWorker>();
}

std::optional<DetectorRun> DetectionSchedule::Next(const cv::Mat& bgr, const FlowStep* flow) {
  const size_t frame = frame_++;
  const bool detect_here = frame % static_cast<size_t>(interval_) == 0;
  if (!background_ || frame == 0) {
    if (!detect_here) return std::nullopt;
    return Run(*detector_, bgr);
  }

  std::optional<DetectorRun> due;
  if (run_.valid()) {
    if (flow != nullptr) steps_.push_back(*flow);
    if (frame == run_frame_ + static_cast<size_t>(interval_)) {
      const auto start = std::chrono::steady_clock::now();
      due = run_.get();
      wait_ms_ += MillisecondsSince(start);
      for (const FlowStep& step : steps_) CarryDetections(step, bgr.size(), &due->detections);
      steps_.clear();
    }
  }
  if (detect_here) {
    // The image is copied: the caller's frame goes on to the mapper while the detector reads it.
    auto task = [this, image = bgr.clone()] { return Run(*detector_, image); };
    run_ = worker_ ? worker_->Submit(std::move(task)) : std::async(std::launch::deferred, task);
    run_frame_ = frame;
  }
  return due;
}

}  // namespace stillmap
