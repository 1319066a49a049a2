// The second-to-last step of a build: the finished map made final in its frame. The cloud is
// cleaned against the final OctoMap while the floor is fitted, then the map frame is chosen and
// the 2-D grid projected. Nothing is written here (map_outputs.h writes the files).
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "build_inputs.h"
#include "map_frame.h"
#include "pose_loops.h"
#include "stillmap/io/cloud_files.h"
#include "stillmap/mapping/mapper.h"
#include "stillmap/mapping/occupancy_grid.h"

namespace stillmap {

// What finishing the map reads of the request.
struct MapFinishOptions {
  MapperOptions mapping;  // its cleaning, min_map_points and depth range (for messages)
  GridOptions grid;
  MapFrameChoice frame;
  bool parallel = true;  // the cleaning beside the floor fit (run.threads > 1)
};

struct FinishedBuildMap {
  FinishedMap map;                // cleaned; its voxel table and views released (cloud has them)
  std::vector<VoxelPoint> cloud;  // its points, in the poses' frame
  MapFigures figures;
  MapFrameFigures frame;
  std::optional<OccupancyGrid> grid;        // when grid.enabled and the OctoMap is on
  double cleaning_ms = 0.0, grid_ms = 0.0;  // the grid's: the floor fit and the projection
};

// Throws std::runtime_error for an empty or nearly empty map, naming what explains it (the
// frames fused, the depth range, `masking`'s share).
FinishedBuildMap FinishMapInFrame(FinishedMap map, const PosedFrames& posed,
                                  const BuildInputs& inputs, const MaskingFigures& masking,
                                  const MapFinishOptions& options);

// The 2-D grid for planners, from the OctoMap (in the poses' frame) and the cleaned cloud, in
// the floor frame, placed in the map frame; nothing when grid.enabled is off or there is no
// OctoMap. `start`: the first camera's position in the poses' frame. `views`: the fused
// keyframes' grid views (FinishedMap::grid_views, taken out before its cloud points; cameras by
// KeyframeView::camera in map.cameras), whose rays find the layers of the band left unseen
// (GridOptions::min_unseen_layer_m; on two threads when `parallel`); none: that check is not
// made.
std::optional<OccupancyGrid> ProjectMapGrid(const FinishedMap& map,
                                            const std::vector<VoxelPoint>& cloud,
                                            const Eigen::Vector3d& start,
                                            const MapFrameFigures& frame,
                                            const GridOptions& options,
                                            const std::vector<KeyframeView>& views, bool parallel);

// The figures of a finished map and its cleaning.
MapFigures MapFiguresOf(const FinishedMap& map, const MapCleaningResult& cleaning);

// Warnings about the finished map that the figures alone do not make plain; `segments_linked`:
// map segments (after a loss of tracking) placed in the map by links to earlier places.
std::vector<std::string> MapWarnings(const MapFigures& map, const MapFrameFigures& frame,
                                     const MapperOptions& options, size_t segments_linked);

}  // namespace stillmap
