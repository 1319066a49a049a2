#include "stillmap/mapping/map_cleaning.h"

#include <pcl/filters/statistical_outlier_removal.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <vector>

#include "stillmap/io/error.h"

namespace stillmap {

void MapCleaningOptions::Validate() const {
  if (outlier_neighbors < 1) throw InputError("mapping.outlier_neighbors must be >= 1");
  if (!(outlier_std_ratio > 0.0)) throw InputError("mapping.outlier_std_ratio must be positive");
}

MapCleaningResult CleanCloud(const MapCleaningOptions& options, const OccupancyMap* occupancy,
                             VoxelCloud* cloud) {
  options.Validate();
  MapCleaningResult result;
  if (options.clear_seen_through && occupancy != nullptr) {
    // Voxels come sorted by (x, y, z) index, so runs of them share an OctoMap leaf: the leaf's
    // verdict is looked up once per run (Bonn: 1.5 M voxels, 620 -> 450 ms with the sort).
    const double leaf = occupancy->resolution();
    Eigen::Vector3i last_leaf(0, 0, 0);
    bool last_free = false;
    bool have_last = false;
    result.seen_through = cloud->RemoveIf([&](const VoxelPoint& point) {
      const Eigen::Vector3i index =
          (point.position.cast<double>() / leaf).array().floor().cast<int>();
      if (!have_last || index != last_leaf) {
        const double probability = occupancy->Occupancy(point.position.cast<double>());
        last_free = probability >= 0.0 && probability < 0.5;  // known and free
        last_leaf = index;
        have_last = true;
      }
      return last_free;
    });
  }
  if (options.outlier_removal &&
      cloud->OutputSize() > static_cast<size_t>(options.outlier_neighbors)) {
    auto points = pcl::make_shared<pcl::PointCloud<pcl::PointXYZ>>();
    points->reserve(cloud->OutputSize());
    cloud->ForEachPoint([&points](const VoxelPoint& point) {
      points->push_back(pcl::PointXYZ(point.position.x(), point.position.y(), point.position.z()));
    });
    pcl::StatisticalOutlierRemoval<pcl::PointXYZ> filter(/*extract_removed_indices=*/true);
    filter.setInputCloud(points);
    filter.setMeanK(options.outlier_neighbors);
    filter.setStddevMulThresh(options.outlier_std_ratio);
    pcl::Indices kept;
    filter.filter(kept);
    std::vector<bool> drop(points->size(), false);
    for (const auto index : *filter.getRemovedIndices()) drop[static_cast<size_t>(index)] = true;
    size_t next = 0;
    result.outliers = cloud->RemoveIf([&drop, &next](const VoxelPoint&) { return drop[next++]; });
  }
  return result;
}

}  // namespace stillmap
