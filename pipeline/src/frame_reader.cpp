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
  if (read_ahead_ && !indices_.empty()) thread_ = std::thread([this] { ReadAhead(); });
}

FrameReader::~FrameReader() {
  if (!thread_.joinable()) return;
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
  }
  changed_.notify_all();
  thread_.join();
}

PreparedFrame FrameReader::Get(size_t k) {
  const auto start = std::chrono::steady_clock::now();
  PreparedFrame frame;
  if (read_ahead_) {
    Slot slot = Take();
    if (slot.error) std::rethrow_exception(slot.error);
    frame = std::move(slot.prepared);
  } else {
    frame = Prepare(indices_[k]);
  }
  wait_ms_ += MillisecondsSince(start);
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

void FrameReader::ReadAhead() {
  for (const size_t index : indices_) {
    {
      std::unique_lock<std::mutex> lock(mutex_);
      changed_.wait(lock, [this] { return stopping_ || queue_.size() < kFramesAhead; });
      if (stopping_) return;
    }
    Slot slot;
    try {
      slot.prepared = Prepare(index);
    } catch (...) {
      slot.error = std::current_exception();
    }
    const bool failed = slot.error != nullptr;
    {
      const std::lock_guard<std::mutex> lock(mutex_);
      queue_.push_back(std::move(slot));
    }
    changed_.notify_all();
    if (failed) return;  // the caller stops at the error
  }
}

FrameReader::Slot FrameReader::Take() {
  std::unique_lock<std::mutex> lock(mutex_);
  changed_.wait(lock, [this] { return !queue_.empty(); });
  Slot slot = std::move(queue_.front());
  queue_.pop_front();
  lock.unlock();
  changed_.notify_all();
  return slot;
}

}  // namespace stillmap
