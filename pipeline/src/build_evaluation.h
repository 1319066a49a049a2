// A build measured against the sequence's ground truth, where it has some: the trajectory (ATE,
// RPE), the map (static_gt.ply: accuracy, completeness, ghosts) and the grid.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "build_inputs.h"
#include "pose_loops.h"
#include "stillmap/io/cloud_files.h"
#include "stillmap/io/evaluation.h"
#include "stillmap/mapping/occupancy_grid.h"

namespace stillmap {

// What the evaluation reads of the request.
struct EvaluationOptions {
  std::string sequence_dir;  // its static_gt.ply and objects.txt, when it has them
  PoseSource poses = PoseSource::kTracking;
  double max_groundtruth_gap_s = 0.0;  // sequence.max_groundtruth_gap
  AteOptions ate;
  RpeOptions rpe;
};

// `posed`, `cloud` and `grid` in the map frame. Not counted in the run's frames per second.
EvaluationFigures EvaluateBuild(const BuildInputs& inputs, const EvaluationOptions& options,
                                const PosedFrames& posed, const std::vector<VoxelPoint>& cloud,
                                const std::optional<OccupancyGrid>& grid);

}  // namespace stillmap
