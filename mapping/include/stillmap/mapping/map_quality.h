// Map quality against a ground-truth static surface (DESIGN.md, "Map quality").
#pragma once

#include <Eigen/Geometry>
#include <vector>

#include "stillmap/mapping/voxel_cloud.h"

namespace stillmap {

struct MapQualityOptions {
  double ghost_distance = 0.05;         // map points farther than this from every static
                                        // ground-truth point are ghosts [m] (DESIGN.md: 5 cm)
  double completeness_distance = 0.05;  // a ground-truth point is covered by a map point within
                                        // this distance [m] (DESIGN.md: 5 cm)
  double surface_distance = 0.03;       // map points within this of a static ground-truth point
                                        // lie on a true surface [m] (issue 47: 3 cm)
};

struct MapQuality {
  size_t map_points = 0;
  size_t groundtruth_points = 0;
  double accuracy_mean = 0.0;     // mean distance of map points to the ground truth [m]
  double accuracy_median = 0.0;   // median of the same [m]
  double completeness = 0.0;      // share of ground-truth points with a map point within 5 cm
  double ghost_share = 0.0;       // share of map points farther than 5 cm from every GT point
  double on_surface_share = 0.0;  // share of map points within 3 cm of a GT point
};

// Nearest-neighbour distances both ways, searched in cells as large as the largest distance
// (cell_grid.h). `groundtruth_from_map` carries the map's points into the truth's frame. The
// truth is taken by value and freed early: pass it with std::move where the caller is done
// with it (the floor's 5.7 M points).
MapQuality EvaluateMap(
    const std::vector<VoxelPoint>& map, std::vector<VoxelPoint> static_groundtruth,
    const MapQualityOptions& options = {},
    const Eigen::Isometry3f& groundtruth_from_map = Eigen::Isometry3f::Identity());

}  // namespace stillmap
