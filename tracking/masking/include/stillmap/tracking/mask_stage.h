// The dynamic-rejection stage of a build: the detector (every n-th frame, on its own thread in the
// background: detection_schedule.h), the masker, the score against ground-truth masks and the
// figures for the report.
#pragma once

#include <Eigen/Geometry>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "stillmap/io/camera.h"
#include "stillmap/io/sequence.h"
#include "stillmap/io/truth_files.h"
#include "stillmap/tracking/detection_schedule.h"
#include "stillmap/tracking/detector.h"
#include "stillmap/tracking/dynamic_mask.h"
#include "stillmap/tracking/flow_check.h"

namespace stillmap {

// What the mask stage did over a run.
struct MaskingStatistics {
  size_t frames = 0;
  size_t frames_with_mask = 0;  // frames with at least one moving pixel
  double share_sum = 0.0;       // sum of the frames' masked shares
  size_t depth_seeds = 0, flow_seeds = 0, high_regions = 0, high_confirmed = 0;
  size_t medium_moving = 0, medium_static = 0, high_static = 0, geometric_only = 0;
  size_t geometric_outlined = 0;  // of geometric_only, outlined as a detected person is
  std::map<std::string, size_t> detections_by_level;  // motion level name -> detections
  std::vector<double> detector_ms, mask_ms;           // per detector run, per frame
  bool detector_in_background = false;                // the detector ran on its own thread
  double detector_wait_ms = 0.0;  // the frame loop waiting for background detector runs
  // Detector runs started, and those that asked the detector's second opinion.
  size_t detector_runs = 0, second_opinion_runs = 0;
  // CPU time of the detector runs, on whichever thread ran them, and of the masks [ms].
  double detector_cpu_ms = 0.0, mask_cpu_ms = 0.0;
  std::optional<MaskScore> score;  // against masks.txt, when it has frames
  // The same over the frames in which a moving object stands still (objects.txt: its pose
  // unchanged since the previous frame) and masks.txt has moving pixels: only semantics can
  // find a person who stands.
  std::optional<MaskScore> score_while_still;

  double MeanShare() const { return frames > 0 ? share_sum / static_cast<double>(frames) : 0.0; }
};

class MaskStage {
 public:
  // `enabled` false: Compute returns empty masks and nothing runs. `detector` may be null
  // (geometry only); `detector_in_background`: its detections are used
  // options.detector_interval frames later, computed on its own thread when `detector_thread`
  // (else when due, on the caller's: the same detections). Ground-truth masks are read from
  // SEQUENCE/masks.txt when it exists.
  MaskStage(const Camera& camera, const DynamicMaskOptions& options, bool enabled,
            std::unique_ptr<Detector> detector, bool detector_in_background,
            const std::string& sequence_dir, bool detector_thread = true);

  bool enabled() const { return enabled_; }
  const DynamicMaskOptions& options() const { return options_; }
  const DynamicMasker* masker() const { return masker_.get(); }
  // "none" when no detector runs.
  const std::string& detector_name() const { return detector_name_; }
  bool semantics() const { return semantics_; }

  // The moving pixels of a frame (CV_8UC1, 255 = moving; empty when masking is off), from its gray
  // image, the flow step from the previous frame (may be null) and its predicted pose (none:
  // the depth check has nothing to project). Throws InputError for an unreadable truth mask.
  cv::Mat Compute(const Frame& frame, const cv::Mat& gray, const FlowStep* flow,
                  const std::optional<Eigen::Isometry3d>& world_from_camera);

  // A keyframe with its mask and pose becomes a depth-check reference. Returns the pixels of
  // earlier keyframes it found moving (DynamicMasker::AddReference).
  std::vector<FoundMoving> AddReference(const Frame& frame, const cv::Mat& mask,
                                        const Eigen::Isometry3d& world_from_camera,
                                        int keyframe_id);
  // The references take their keyframes' corrected poses (after a loop correction).
  void Repose(const std::map<int, Eigen::Isometry3d>& world_from_keyframe);

  // After the last frame: the detector (its network) and the depth check's references are freed;
  // the figures stay. Compute and AddReference may not be called after.
  void EndFrames();

  // The figures so far (the score set when truth masks were found for some frame).
  MaskingStatistics statistics() const;

 private:
  bool enabled_;
  DynamicMaskOptions options_;
  TruthMasks truth_;
  std::set<long long> still_frames_us_;            // times of frames with a still object [us]
  std::unique_ptr<DetectionSchedule> detections_;  // null: no detector, or semantics off
  bool semantics_ = false;                         // a detector runs (detections_ until EndFrames)
  std::string detector_name_ = "none";
  std::unique_ptr<DynamicMasker> masker_;
  MaskScore score_;
  MaskScore still_score_;
  MaskingStatistics statistics_;
};

}  // namespace stillmap
