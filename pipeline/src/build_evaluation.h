// A build measured against the sequence's ground truth, where it has some: the trajectory (ATE,
// RPE), the map (static_gt.ply: accuracy, completeness, ghosts) and the grid.
#pragma once

#include <vector>

#include "build_inputs.h"
#include "pose_loops.h"
#include "stillmap/io/cloud_files.h"

namespace stillmap {

// Fills result->evaluation. Not counted in the run's frames per second.
void EvaluateBuild(const BuildInputs& inputs, const BuildRequest& request, const PosedFrames& posed,
                   const std::vector<VoxelPoint>& cloud, BuildResult* result);

}  // namespace stillmap
