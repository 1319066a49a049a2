// The last step of a build (and of a merge): the finished map's files, written into the staged
// output set. Nothing here changes the map; map_finish.h makes it final first.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "map_finish.h"
#include "pose_loops.h"
#include "stillmap/io/cloud_files.h"
#include "stillmap/io/evaluation.h"
#include "stillmap/io/output_files.h"
#include "stillmap/mapping/map_mesh.h"
#include "stillmap/pipeline/config.h"
#include "stillmap/viewer/renders.h"

namespace stillmap {

// What the map files read of the configuration.
struct MapFileOptions {
  MapMeshOptions mesh;
  double voxel_leaf_m = 0.0;  // mapping.voxel_leaf_size, for the cloud files' header
  bool parallel = true;       // the OctoMap and the mesh on other threads (run.threads > 1)
};

// The files of a finished map in the frame `frame`: grid.pgm/yaml (when `grid`), map.bt/ot,
// map.ply/pcd and the mesh (made from the cloud as it is written). Moves `cloud` from the poses'
// frame into the map frame; adds the grid's writing to timings->grid_ms, sets mesh_ms. Returns
// the mesh's figures when mesh.enabled. Throws std::runtime_error for an empty mesh.
std::optional<MeshFigures> WriteMapFiles(const FinishedMap& map, std::vector<VoxelPoint>* cloud,
                                         const MapFrameFigures& frame,
                                         const std::optional<OccupancyGrid>& grid,
                                         const MapFileOptions& options, OutputSet& outputs,
                                         StageTimings* timings);

// A build's own files besides the map's: session.bin (from posed->session_keyframes, which it
// takes), trajectory.txt and keyframes.txt (`posed` is moved into the map frame `frame` first)
// and config.yaml (`config`, so that `--config OUT/config.yaml` repeats the run).
void WriteBuildFiles(PosedFrames* posed, const MapFrameFigures& frame, const BuildInputs& inputs,
                     const BuildConfig& config, const std::string& sequence_dir, PoseSource poses,
                     OutputSet& outputs);

// Writes `text` to `path`; a failed write throws std::runtime_error saying why, naming the
// output `name` (report.json, config.yaml, ...).
void WriteText(const std::string& path, const std::string& text, const char* name);

// What the renders show besides the cloud.
struct RenderSources {
  const std::optional<OccupancyGrid>* grid = nullptr;
  const PosedFrames* posed = nullptr;
  const std::optional<AteResult>* ate = nullptr;  // its error plot, when evaluated
  std::string title;
};

// renders/: top views of the cloud and grid, the trajectory error plot when the trajectory was
// evaluated. Returns the files written (under renders/).
std::vector<std::string> WriteRenders(std::vector<VoxelPoint> cloud, const RenderSources& sources,
                                      const RenderOptions& options, OutputSet& outputs);

}  // namespace stillmap
