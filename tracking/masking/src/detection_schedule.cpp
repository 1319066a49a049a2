#include "stillmap/tracking/detection_schedule.h"

#include <chrono>

#include "stillmap/io/cpu_usage.h"
#include "stillmap/io/timing.h"
#include "stillmap/tracking/dynamic_mask.h"

namespace stillmap {
namespace {

DetectorRun Run(Detector& detector, const cv::Mat& bgr, bool second_opinion) {
  const auto start = std::chrono::steady_clock::now();
  const double cpu = ThreadCpuMs();
  DetectorRun run;
  run.detections = second_opinion ? detector.DetectWithSecondOpinion(bgr) : detector.Detect(bgr);
  run.ms = MillisecondsSince(start);
  run.cpu_ms = ThreadCpuMs() - cpu;
  return run;
}

}  // namespace

DetectionSchedule::DetectionSchedule(std::unique_ptr<Detector> detector, int interval,
                                     bool background, bool own_thread, double second_opinion_share)
    : detector_(std::move(detector)),
      interval_(interval),
      background_(background),
      second_opinion_share_(second_opinion_share) {
  CV_Assert(detector_ != nullptr && interval_ >= 1);
  if (background_ && own_thread) worker_ = std::make_unique<SerialWorker>();
}

bool DetectionSchedule::AskSecondOpinion(bool wanted) {
  ++runs_;
  if (!detector_->has_second_opinion()) return false;
  // Counted from the first run, so a quiet stretch leaves room for a busy one after it.
  const bool allowed =
      static_cast<double>(second_runs_ + 1) <= second_opinion_share_ * static_cast<double>(runs_);
  if (!(wanted && allowed)) return false;
  ++second_runs_;
  return true;
}

std::optional<DetectorRun> DetectionSchedule::Next(const cv::Mat& bgr, const FlowStep* flow,
                                                   bool wants_second_opinion) {
  const size_t frame = frame_++;
  const bool detect_here = frame % static_cast<size_t>(interval_) == 0;
  if (!background_ || frame == 0) {
    if (!detect_here) return std::nullopt;
    return Run(*detector_, bgr, AskSecondOpinion(wants_second_opinion));
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
    const bool second = AskSecondOpinion(wants_second_opinion);
    auto task = [this, image = bgr.clone(), second] { return Run(*detector_, image, second); };
    run_ = worker_ ? worker_->Submit(std::move(task)) : std::async(std::launch::deferred, task);
    run_frame_ = frame;
  }
  return due;
}

}  // namespace stillmap
