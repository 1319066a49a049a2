#include "frame_reader.h"

#include <chrono>
#include <opencv2/imgproc.hpp>

#include "stillmap/io/cpu_usage.h"
#include "stillmap/io/timing.h"

namespace stillmap {

FrameReader::FrameReader(const Sequence& sequence, std::vector<size_t> indices, bool read_ahead,
                         std::optional<FlowTracker> flow)
    : sequence_(sequence),
      indices_(std::move(indices)),
      read_ahead_(read_ahead),
      flow_(std::move(flow)) {
  if (read_ahead_ && !indices_.empty()) Schedule(0);
}

PreparedFrame FrameReader::Get(size_t k) {
  const auto start = std::chrono::steady_clock::now();
  PreparedFrame frame = read_ahead_ ? next_.get() : Prepare(indices_[k]);
  wait_ms_ += MillisecondsSince(start);
  if (read_ahead_ && k + 1 < indices_.size()) Schedule(k + 1);
  if (frame.flow) flow_ms_.push_back(frame.flow->ms);
  if (read_ahead_) ahead_cpu_ms_ += frame.cpu_ms;
  return frame;
}

PreparedFrame FrameReader::Prepare(size_t index) {
  const double cpu = ThreadCpuMs();
  PreparedFrame prepared;
  prepared.frame = sequence_.LoadFrame(index);
  checks_.Add(prepared.frame);
  cv::cvtColor(prepared.frame.color, prepared.gray, cv::COLOR_BGR2GRAY);
  if (flow_) prepared.flow = flow_->Next(prepared.gray);
  prepared.cpu_ms = ThreadCpuMs() - cpu;
  return prepared;
}

void FrameReader::Schedule(size_t k) {
  next_ = std::async(std::launch::async, [this, index = indices_[k]] { return Prepare(index); });
}

}  // namespace stillmap
