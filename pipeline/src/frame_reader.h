// Frames decoded and prepared in order, up to a few ahead on another thread.
#pragma once

#include <condition_variable>
#include <cstddef>
#include <deque>
#include <exception>
#include <mutex>
#include <optional>
#include <thread>
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
  ~FrameReader();  // stops the reading thread after the frame it is on

  size_t size() const { return indices_.size(); }
  // The k-th frame (k counts up from 0 by one on each call). Throws InputError for a bad image
  // (frames after a bad one are not read).
  PreparedFrame Get(size_t k);
  double wait_ms() const { return wait_ms_; }  // waiting for frames in total
  // CPU time of decoding and preparing the frames on the reading thread (read_ahead) [ms].
  double ahead_cpu_ms() const { return ahead_cpu_ms_; }
  const std::vector<double>& flow_ms() const { return flow_ms_; }
  // What the frames show of the streams' plausibility (call after the last frame's Get).
  const StreamChecks& checks() const { return checks_; }

 private:
  // A prepared frame, or the error preparing it.
  struct Slot {
    PreparedFrame prepared;
    std::exception_ptr error;
  };

  PreparedFrame Prepare(size_t index);
  void ReadAhead();  // the reading thread
  Slot Take();       // the next slot from the reading thread, waiting for it

  const Sequence& sequence_;
  std::vector<size_t> indices_;
  bool read_ahead_;
  std::optional<FlowTracker> flow_;  // used by one Prepare at a time, frames in order
  std::mutex mutex_;
  std::condition_variable changed_;  // a slot queued or taken, or stopping
  std::deque<Slot> queue_;           // prepared, not yet taken (at most kFramesAhead)
  bool stopping_ = false;
  std::thread thread_;  // last: started when everything it uses exists
  double wait_ms_ = 0.0;
  double ahead_cpu_ms_ = 0.0;
  std::vector<double> flow_ms_;
  StreamChecks checks_;  // updated by Prepare, frames in order
};

}  // namespace stillmap
