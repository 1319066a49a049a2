// The per-frame loop of a build, one for each pose source: every frame read, masked, given a
// pose and (as a keyframe, or every frame with known poses) fused into the map.
#pragma once

#include <vector>

#include "build_inputs.h"
#include "frame_reader.h"
#include "keyframe_fuser.h"
#include "memory_ledger.h"
#include "segment_keeper.h"
#include "stillmap/io/session_keyframes.h"
#include "stillmap/io/trajectory.h"
#include "stillmap/mapping/mapper.h"
#include "stillmap/pipeline/dense_refinement_options.h"
#include "stillmap/pipeline/progress.h"
#include "stillmap/tracking/mask_stage.h"
#include "stillmap/tracking/trajectory_smoothing.h"

namespace stillmap {

struct PosedFrames {
  Trajectory trajectory;                 // every frame with a pose
  std::vector<StampedPose> fused_poses;  // the frames fused, with the poses they were fused at
  // The fused keyframes for session.bin (poses in the poses' frame; empty without a record).
  SessionKeyframeList session_keyframes;
  double session_depth_unit_m = 0.0;  // the step of their depth PNGs [m]
};

// What the frame loops read of the request.
struct LoopOptions {
  PoseSource poses = PoseSource::kTracking;
  TrackerOptions tracking;               // tracked runs
  FuserOptions fuser;                    // tracked runs
  MapSegmentOptions segments;            // tracked runs: joining segments after a loss (merge.*)
  DenseRefinementOptions refinement;     // tracked runs: the final poses refined (final_poses.*)
  TrajectorySmoothingOptions smoothing;  // tracked runs: the frames' poses (final_poses.*)
  // With ground-truth poses every n-th frame is a depth-check reference
  // (masking.groundtruth_reference_interval).
  int groundtruth_reference_interval = 5;
  // Given poses used as they are: a frame is fused when the camera moved or turned this much
  // since the last one fused (poses.keyframe_*; 0 and 0: every frame, as with the ground truth).
  double keyframe_distance_m = 0.0, keyframe_angle_deg = 0.0;
  bool FusesEveryFrame() const { return keyframe_distance_m <= 0.0 && keyframe_angle_deg <= 0.0; }
  bool given_session = false;  // given poses as they are, with map.session_record
  bool flow = false;           // the flow check's corners are tracked ahead with the decoding
  bool read_ahead = true;      // frames decoded on another thread (run.threads > 1)
  bool parallel = true;        // the final poses' refinement on two threads (run.threads > 1)
  bool show_progress = false;
};

// What the frame loop gives the build result.
struct LoopResult {
  PosedFrames posed;
  std::optional<TrackingFigures> tracking;  // tracked runs
  SelectionFigures selection;               // tracked runs
  std::vector<SegmentSummary> segments;     // tracked runs: every map segment
  SegmentLinkFigures segment_links;         // tracked runs
  std::vector<ApartSegment> apart;          // the segments never joined, to be written apart
  MaskingStatistics masking;
  double depth_median_m = 0.0, depth_95th_percentile_m = 0.0;  // every depth reading's
  size_t frozen_colour = 0;  // colour frames equal to the one before
  double reader_cpu_ms = 0.0, load_wait_ms = 0.0;
  std::vector<double> flow_ms;
  std::vector<std::string> warnings;  // the streams' plausibility
};

// Reads, masks, poses and fuses every frame of `inputs` (the masks' and mapper's state carries
// on). Throws std::runtime_error when no frame could be tracked.
LoopResult RunPoseLoop(const BuildInputs& inputs, const LoopOptions& options, MaskStage& masks,
                       Mapper& mapper, MemoryLedger& memory);

// The steps every loop shares.
struct LoopStages {
  FrameReader& reader;
  MaskStage& masks;
  Mapper& mapper;
  ProgressLine& progress;
  MemoryLedger& memory;
};

// The frame loops sample the memory (memory_ledger.h) on every this many frames read.
constexpr size_t kMemorySampleFrames = 30;
// Samples the memory: the mapper's and the reader's owners, with `owners` the loop's own [bytes].
void SampleLoopMemory(const LoopStages& stages, double time,
                      std::vector<std::pair<std::string, size_t>> owners = {});

// With known poses, which frames are read, masked and fused (positions in inputs.frame_indices):
// every n-th frame is a depth-check reference, and every frame is fused (or, with a keyframe
// distance or angle, those the camera reached by moving or turning that much since the last).
// Only those are read and masked, and a flow step goes from the frame masked before: the masks
// carry their detections over it (busy_office's ghosts 0.19 -> 0.07 % against steps from the
// frame just before, crowd_start's 0.14 -> 0.09 %).
struct KnownPosePlan {
  std::vector<size_t> read;           // the frames fused or references, ascending
  std::vector<bool> fuse, reference;  // one per frame
};
KnownPosePlan PlanKnownPoseFrames(const BuildInputs& inputs, const LoopOptions& options);

// With known poses (the ground truth's, or given ones used as they are): the frames of `plan`,
// read by stages.reader in the order of plan.read, masked, fused and made references.
PosedFrames RunGroundTruthLoop(const BuildInputs& inputs, const LoopOptions& options,
                               const KnownPosePlan& plan, LoopStages stages);

// With given poses used as they are and a keyframe rule: the frames of `plan` masked as by
// RunGroundTruthLoop, those to fuse held until the frames after them within the depth check's
// horizon have come, then fused as tracked keyframes are (KeyframeFuser: the map re-check
// against the frames on both sides, the masked-share and revisit rules). Fills
// result->selection.
PosedFrames RunGivenPoseLoop(const BuildInputs& inputs, const LoopOptions& options,
                             const KnownPosePlan& plan, LoopStages stages, LoopResult* result);

// With tracked poses: keyframes are fused once their pose is final (they left the bundle
// adjustment window), those of map segments not joined to the first kept apart (segment_keeper.h).
// Fills result->tracking, result->selection, result->segments and result->apart. Throws
// std::runtime_error when no frame could be tracked.
PosedFrames RunTrackedLoop(const BuildInputs& inputs, const LoopOptions& options, LoopStages stages,
                           LoopResult* result);

}  // namespace stillmap
