// The per-frame loop of a build, one for each pose source: every frame read, masked, given a
// pose and (as a keyframe, or every frame with known poses) fused into the map.
#pragma once

#include <vector>

#include "build_inputs.h"
#include "frame_reader.h"
#include "stillmap/io/session_record.h"
#include "stillmap/io/trajectory.h"
#include "stillmap/mapping/mapper.h"
#include "stillmap/pipeline/progress.h"
#include "stillmap/tracking/mask_stage.h"

namespace stillmap {

struct PosedFrames {
  Trajectory trajectory;                 // every frame with a pose
  std::vector<StampedPose> fused_poses;  // the frames fused, with the poses they were fused at
  // The fused keyframes for session.bin (poses in the poses' frame; empty without a record).
  std::vector<SessionKeyframeBlocks> session_keyframes;
  double session_depth_unit_m = 0.0;  // the step of their depth PNGs [m]
};

// The steps every loop shares.
struct LoopStages {
  FrameReader& reader;
  MaskStage& masks;
  Mapper& mapper;
  ProgressLine& progress;
};

// With the ground truth's poses: every frame is fused; every
// config.groundtruth_reference_interval-th one becomes a depth-check reference.
PosedFrames RunGroundTruthLoop(const BuildInputs& inputs, const BuildConfig& config,
                               LoopStages stages);

// With tracked poses: keyframes are fused once their pose is final (they left the bundle
// adjustment window). Fills result->tracking and result->selection. Throws std::runtime_error
// when no frame could be tracked.
PosedFrames RunTrackedLoop(const BuildInputs& inputs, const BuildRequest& request,
                           LoopStages stages, BuildResult* result);

}  // namespace stillmap
