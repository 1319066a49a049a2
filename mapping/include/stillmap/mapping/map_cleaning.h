// Clean-up of the finished voxel cloud: voxels the OctoMap's rays later saw through (whatever
// stood there moved away) and, optionally, PCL's statistical outliers.
#pragma once

#include <cstddef>

#include "stillmap/mapping/occupancy_map.h"
#include "stillmap/mapping/voxel_cloud.h"

namespace stillmap {

struct MapCleaningOptions {
  // Drop cloud voxels whose OctoMap leaf ends free: later rays passed through the place, so what
  // was fused there has gone (a person the mask missed in one keyframe). Needs the OctoMap.
  bool clear_seen_through = true;
  // PCL StatisticalOutlierRemoval: a voxel whose mean distance to its outlier_neighbors nearest
  // voxels exceeds the cloud's mean of that distance by outlier_std_ratio standard deviations.
  bool outlier_removal = false;
  int outlier_neighbors = 16;
  double outlier_std_ratio = 2.0;

  // Throws InputError naming the first impossible value.
  void Validate() const;
};

struct MapCleaningResult {
  size_t seen_through = 0;  // voxels removed because the OctoMap calls their place free
  size_t outliers = 0;      // voxels removed as statistical outliers
};

// Removes the voxels named above from `cloud` (occupancy may be null: no see-through check).
MapCleaningResult CleanCloud(const MapCleaningOptions& options, const OccupancyMap* occupancy,
                             VoxelCloud* cloud);

}  // namespace stillmap
