// When the detector runs and when its detections are used (issue 17). The detector runs on every
// n-th frame. In the background it runs on its own thread, off the tracking path, and its
// detections are used n frames later, carried there by the flow of the points inside them (as
// NGD-SLAM runs its detector). The schedule is fixed by frame numbers, not by timing: a build
// repeats whatever the machine's load. The first frame is always detected in place, so that the
// people in view from the start are known before the first keyframe.
#pragma once

#include <future>
#include <memory>
#include <optional>
#include <vector>

#include "stillmap/io/serial_worker.h"
#include "stillmap/tracking/detector.h"
#include "stillmap/tracking/flow_check.h"

namespace stillmap {

// A detector run: its detections (for the frame it ran on, carried since) and its time.
struct DetectorRun {
  std::vector<Detection> detections;
  double ms = 0.0;
  double cpu_ms = 0.0;  // of the thread that ran it (OpenCV's workers do part of the work)
};

class DetectionSchedule {
 public:
  // `interval`: the detector runs on every interval-th frame (>= 1). `background`: its detections
  // are used `interval` frames later, the run on its own thread when `own_thread` (else when its
  // result is due, on the caller's thread: the same detections, so one thread repeats many);
  // otherwise in place.
  // `second_opinion_share`: for a detector with a second opinion, the most of its runs that may
  // ask for it.
  DetectionSchedule(std::unique_ptr<Detector> detector, int interval, bool background,
                    bool own_thread = true, double second_opinion_share = 0.0);
  DetectionSchedule(const DetectionSchedule&) = delete;
  DetectionSchedule& operator=(const DetectionSchedule&) = delete;
  // The worker ends after the run in flight (a deferred run is dropped unrun).
  ~DetectionSchedule() = default;

  // Frames in order, one call each: the colour image (CV_8UC3) and the flow step from the previous
  // frame (null when flow is not tracked: background detections are then used uncarried). Returns
  // the detections that hold for this frame when a run's result is due now, else nothing (the
  // caller carries the last ones by flow). `wants_second_opinion`: a run started on this frame
  // asks the detector's second opinion, when it has one and the share allows.
  std::optional<DetectorRun> Next(const cv::Mat& bgr, const FlowStep* flow,
                                  bool wants_second_opinion = false);

  const Detector& detector() const { return *detector_; }
  // Time the caller spent waiting for background runs [ms].
  double wait_ms() const { return wait_ms_; }
  // Detector runs started, and those of them that asked the second opinion.
  size_t runs() const { return runs_; }
  size_t second_opinion_runs() const { return second_runs_; }

 private:
  std::unique_ptr<Detector> detector_;
  int interval_;
  bool background_;
  double second_opinion_share_;
  // The thread of the background runs, one for all of them (declared after the detector it
  // uses: it ends first).
  std::unique_ptr<SerialWorker> worker_;
  size_t frame_ = 0;              // frames seen
  std::future<DetectorRun> run_;  // the background run in flight, if any
  size_t run_frame_ = 0;          // the frame it runs on
  std::vector<FlowStep> steps_;   // flow steps since that frame, to carry its detections
  double wait_ms_ = 0.0;
  size_t runs_ = 0, second_runs_ = 0;

  // Whether the run about to start asks the second opinion (and counts it).
  bool AskSecondOpinion(bool wanted);
};

}  // namespace stillmap
