// The map outputs of a build, written into the staged output set.
#pragma once

#include <optional>
#include <vector>

#include "build_inputs.h"
#include "pose_loops.h"
#include "stillmap/io/cloud_files.h"
#include "stillmap/io/output_files.h"
#include "stillmap/mapping/mapper.h"

namespace stillmap {

// Finishes and writes the map: the cloud is cleaned against the final OctoMap on another thread
// while the floor is fitted to the OctoMap; then the map frame is chosen, the grid projected,
// and the OctoMap files, the cloud files, the mesh (on other threads), trajectory.txt,
// keyframes.txt and config.yaml written. Fills
// result->map, mesh, grid, timings and warnings. Returns the cloud's points for the evaluation
// and the renders. Throws std::runtime_error for an empty map or mesh (nothing is committed).
// The 3-D outputs are in the map frame (config.map.frame, result->map_frame), and so are `posed`
// and the cloud afterwards.
std::vector<VoxelPoint> WriteMapOutputs(FinishedMap map, PosedFrames* posed,
                                        const BuildInputs& inputs, const BuildRequest& request,
                                        OutputSet& outputs, BuildResult* result);

// The files of a cleaned map, in the frame `frame` (the cloud's points and `start`, the first
// camera's position, in the poses' frame): grid.pgm/yaml (when enabled), map.bt/ot, map.ply/pcd
// and the mesh, the OctoMap and mesh on other threads when `parallel`. Moves `cloud` into the map
// frame; sets timings->grid_ms and mesh_ms. Throws std::runtime_error for an empty mesh.
struct MapFiles {
  std::optional<OccupancyGrid> grid;
  MeshFigures mesh;
};
MapFiles WriteMapFiles(const FinishedMap& map, std::vector<VoxelPoint>* cloud,
                       const MapFrameFigures& frame, const Eigen::Vector3d& start_in_poses,
                       const BuildConfig& config, bool parallel, OutputSet& outputs,
                       StageTimings* timings);

// The figures of a finished map and its cleaning.
MapFigures MapFiguresOf(const FinishedMap& map, const MapCleaningResult& cleaning);

// The renders (renders/: top views of the cloud and grid, the trajectory error plot when the
// trajectory was evaluated) into the staged set; sets result->renders.
void WriteRenders(std::vector<VoxelPoint> cloud, const PosedFrames& posed,
                  const BuildRequest& request, OutputSet& outputs, BuildResult* result);

}  // namespace stillmap
