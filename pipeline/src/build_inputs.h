// The first step of a build: the inputs opened and checked before anything is written.
#pragma once

#include <vector>

#include "stillmap/io/camera.h"
#include "stillmap/io/sequence.h"
#include "stillmap/io/trajectory.h"
#include "stillmap/pipeline/build_request.h"
#include "stillmap/pipeline/build_result.h"

namespace stillmap {

struct BuildInputs {
  Camera camera;
  Sequence sequence;
  std::vector<size_t> frame_indices;  // the frames to process, in order
  // With --poses groundtruth: the pose of each frame of frame_indices (frames without one are
  // left out of frame_indices and never decoded).
  std::vector<StampedPose> groundtruth_poses;
};

// Opens the sequence of `request`, picks its frames and fills result->frames' input counts.
// Throws InputError for a missing folder, bad lists or camera, a frame range beyond the sequence,
// ground-truth poses missing or beyond the maps' reach.
BuildInputs OpenInputs(const BuildRequest& request, BuildResult* result);

}  // namespace stillmap
