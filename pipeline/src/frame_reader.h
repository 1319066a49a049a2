// Frames decoded and prepared in order, up to a few ahead on another thread.
#pragma once

#include <cstddef>
#include <deque>
#include <future>
#include <memory>
#include <optional>
#include <vector>

#include "stillmap/io/sequence.h"
#include "stillmap/io/serial_worker.h"
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
  // With `read_ahead`, one thread decodes and prepares the frames in order, up to this many
  // ahead of the caller: the caller's pace varies from frame to frame (keyframes, detections,
  // the bundle adjustment's thread taking a core), and a queue lets the reading use a core
  // whenever one is free instead of only while the caller works on the frame before.
  static constexpr size_t kFramesAhead = 4;

  // Reads sequence frames `indices` in order; with `read_ahead` on another thread while the
  // caller works (kFramesAhead). `flow`: the flow tracker of the masking (none: no flow steps).
  FrameReader(const Sequence& sequence, std::vector<size_t> indices, bool read_ahead,
              std::optional<FlowTracker> flow);
  FrameReader(const FrameReader&) = delete;
  FrameReader& operator=(const FrameReader&) = delete;

  size_t size() const { return indices_.size(); }
  // The k-th frame (k counts up from 0 by one on each call). Throws InputError for a bad image
  // (when frame k's own image is bad: frames read ahead of it do not matter).
  PreparedFrame Get(size_t k);
  double wait_ms() const { return wait_ms_; }  // waiting for frames in total
  // CPU time of decoding and preparing the frames on the reading thread (read_ahead) [ms].
  double ahead_cpu_ms() const { return ahead_cpu_ms_; }
  const std::vector<double>& flow_ms() const { return flow_ms_; }
  // The frames queued ahead, at the decoded size of the last one taken [bytes].
  size_t ahead_bytes() const { return ahead_.size() * frame_bytes_; }
  // What the frames show of the streams' plausibility (call after the last frame's Get).
  const StreamChecks& checks() const { return checks_; }

 private:
  PreparedFrame Prepare(size_t index);
  void Schedule(size_t k);  // queues frame k on the reading thread

  const Sequence& sequence_;
  std::vector<size_t> indices_;
  bool read_ahead_;
  std::optional<FlowTracker> flow_;               // used by one Prepare at a time, frames in order
  std::deque<std::future<PreparedFrame>> ahead_;  // queued in order, at most kFramesAhead
  double wait_ms_ = 0.0;
  double ahead_cpu_ms_ = 0.0;
  size_t frame_bytes_ = 0;  // colour, depth and grey of the last frame taken
  std::vector<double> flow_ms_;
  StreamChecks checks_;  // updated by Prepare, frames in order
  // The reading thread (last: it ends first, after the frames queued, before what they use).
  std::unique_ptr<SerialWorker> worker_;
};

}  // namespace stillmap
