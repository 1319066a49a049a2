// Frames decoded and prepared in order, the next one ahead on another thread.
#pragma once

#include <future>
#include <optional>
#include <vector>

#include "stillmap/io/sequence.h"
#include "stillmap/tracking/flow_check.h"
#include "stream_checks.h"

namespace stillmap {

// A decoded frame with the work that needs nothing but its images: its gray image and, when
// masking tracks flow, the flow step from the previous frame.
struct PreparedFrame {
  Frame frame;
  cv::Mat gray;
  std::optional<FlowStep> flow;
  double cpu_ms = 0.0;  // CPU time of decoding and preparing it, on whichever thread did it
};

class FrameReader {
 public:
  // Reads sequence frames `indices` in order; with `read_ahead` the next one is decoded on
  // another thread while the caller works on the current one. `flow`: the flow tracker of the
  // masking (none: no flow steps).
  FrameReader(const Sequence& sequence, std::vector<size_t> indices, bool read_ahead,
              std::optional<FlowTracker> flow);
  FrameReader(const FrameReader&) = delete;
  FrameReader& operator=(const FrameReader&) = delete;

  size_t size() const { return indices_.size(); }
  // The k-th frame (k counts up from 0 by one on each call). Throws InputError for a bad image.
  PreparedFrame Get(size_t k);
  double wait_ms() const { return wait_ms_; }  // waiting for frames in total
  // CPU time of decoding and preparing the frames on the reading thread (read_ahead) [ms].
  double ahead_cpu_ms() const { return ahead_cpu_ms_; }
  const std::vector<double>& flow_ms() const { return flow_ms_; }
  // What the frames read so far show of the streams' plausibility (call between Get calls).
  const StreamChecks& checks() const { return checks_; }

 private:
  PreparedFrame Prepare(size_t index);
  void Schedule(size_t k);

  const Sequence& sequence_;
  std::vector<size_t> indices_;
  bool read_ahead_;
  std::optional<FlowTracker> flow_;  // used by one Prepare at a time, frames in order
  std::future<PreparedFrame> next_;
  double wait_ms_ = 0.0;
  double ahead_cpu_ms_ = 0.0;
  std::vector<double> flow_ms_;
  StreamChecks checks_;  // updated by Prepare, frames in order
};

}  // namespace stillmap
