// The map outputs of a build, written into the staged output set.
#pragma once

#include <vector>

#include "build_inputs.h"
#include "pose_loops.h"
#include "stillmap/io/cloud_files.h"
#include "stillmap/io/output_files.h"
#include "stillmap/mapping/mapper.h"

namespace stillmap {

// Finishes and writes the map: the cloud is cleaned against the final OctoMap on another thread
// while the OctoMap files and the grid (which only read the OctoMap) are written, then the cloud
// files, the mesh (on another thread), trajectory.txt, keyframes.txt and config.yaml. Fills
// result->map, mesh, grid, timings and warnings. Returns the cloud's points for the evaluation
// and the renders. Throws std::runtime_error for an empty map or mesh (nothing is committed).
std::vector<VoxelPoint> WriteMapOutputs(FinishedMap map, const PosedFrames& posed,
                                        const BuildRequest& request, const Camera& camera,
                                        OutputSet& outputs, BuildResult* result);

// The renders (renders/: top views of the cloud and grid, the trajectory error plot when the
// trajectory was evaluated) into the staged set; sets result->renders.
void WriteRenders(std::vector<VoxelPoint> cloud, const PosedFrames& posed,
                  const BuildRequest& request, OutputSet& outputs, BuildResult* result);

}  // namespace stillmap
