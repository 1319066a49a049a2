#include "stillmap/mapping/map_quality.h"

#include <pcl/kdtree/kdtree_flann.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <thread>

namespace stillmap {
namespace {

pcl::PointCloud<pcl::PointXYZ>::Ptr ToPcl(const std::vector<VoxelPoint>& points) {
  pcl::PointCloud<pcl::PointXYZ>::Ptr cloud(new pcl::PointCloud<pcl::PointXYZ>);
  cloud->resize(points.size());
  for (size_t i = 0; i < points.size(); ++i) (*cloud)[i].getVector3fMap() = points[i].position;
  return cloud;
}

// Distance from every query point to its nearest neighbour in `tree`, searched within `radius`
// only (an exact search is slow for points far from every data point: 415 s for the ghosts of a
// walking sequence). Points without a neighbour in that radius get +infinity. Two threads.
std::vector<float> NearestWithin(const pcl::KdTreeFLANN<pcl::PointXYZ>& tree,
                                 const pcl::PointCloud<pcl::PointXYZ>& queries, double radius) {
  std::vector<float> distances(queries.size());
  auto run = [&](size_t begin, size_t end) {
    std::vector<int> index;
    std::vector<float> squared;
    for (size_t i = begin; i < end; ++i) {
      distances[i] = tree.radiusSearch(queries[i], radius, index, squared, 1) > 0
                         ? std::sqrt(squared[0])
                         : std::numeric_limits<float>::infinity();
    }
  };
  std::thread helper(run, 0, queries.size() / 2);
  run(queries.size() / 2, queries.size());
  helper.join();
  return distances;
}

// The exact distance to a 2.5 cm subsample of the ground truth, small enough to search
// exhaustively; off by at most 2.2 cm for points at least 5 cm away.
pcl::PointCloud<pcl::PointXYZ>::Ptr CoarseCloud(const std::vector<VoxelPoint>& points) {
  VoxelCloudOptions coarse_options;
  coarse_options.leaf_size = 0.025;
  VoxelCloud voxels(coarse_options);
  ColoredPoints colored;
  for (const VoxelPoint& p : points) {
    colored.positions.push_back(p.position);
    colored.colors.push_back(p.rgb);
  }
  voxels.Insert(colored);
  return ToPcl(voxels.Points());
}

// Accuracy and ghosts: the map against the ground truth. Its search trees go before the
// completeness builds the map's own (the two together were the evaluation's peak).
void MeasureAccuracy(const pcl::PointCloud<pcl::PointXYZ>& map_cloud,
                     const std::vector<VoxelPoint>& static_groundtruth,
                     const MapQualityOptions& options, MapQuality* quality) {
  pcl::KdTreeFLANN<pcl::PointXYZ> groundtruth_tree;
  groundtruth_tree.setInputCloud(ToPcl(static_groundtruth));
  std::vector<float> to_groundtruth =
      NearestWithin(groundtruth_tree, map_cloud, options.ghost_distance);
  // Ghosts (nothing within the radius): their distance to the coarse ground truth.
  pcl::KdTreeFLANN<pcl::PointXYZ> coarse_tree;
  coarse_tree.setInputCloud(CoarseCloud(static_groundtruth));
  std::vector<int> index(1);
  std::vector<float> squared(1);
  size_t ghosts = 0, on_surface = 0;
  double sum = 0.0;
  for (size_t i = 0; i < to_groundtruth.size(); ++i) {
    if (to_groundtruth[i] <= options.surface_distance) ++on_surface;
    if (std::isinf(to_groundtruth[i])) {
      ++ghosts;
      coarse_tree.nearestKSearch(map_cloud[i], 1, index, squared);
      to_groundtruth[i] =
          std::max(static_cast<float>(options.ghost_distance), std::sqrt(squared[0]));
    }
    sum += to_groundtruth[i];
  }
  quality->accuracy_mean = sum / static_cast<double>(to_groundtruth.size());
  quality->ghost_share = static_cast<double>(ghosts) / static_cast<double>(to_groundtruth.size());
  quality->on_surface_share =
      static_cast<double>(on_surface) / static_cast<double>(to_groundtruth.size());
  std::nth_element(to_groundtruth.begin(), to_groundtruth.begin() + to_groundtruth.size() / 2,
                   to_groundtruth.end());
  quality->accuracy_median = to_groundtruth[to_groundtruth.size() / 2];
}

}  // namespace

MapQuality EvaluateMap(const std::vector<VoxelPoint>& map,
                       const std::vector<VoxelPoint>& static_groundtruth,
                       const MapQualityOptions& options) {
  MapQuality quality;
  quality.map_points = map.size();
  quality.groundtruth_points = static_groundtruth.size();
  if (map.empty() || static_groundtruth.empty()) return quality;
  const auto map_cloud = ToPcl(map);
  MeasureAccuracy(*map_cloud, static_groundtruth, options, &quality);

  pcl::KdTreeFLANN<pcl::PointXYZ> map_tree;
  map_tree.setInputCloud(map_cloud);
  // The truth as queries is made again rather than kept from the accuracy's tree: kept, it would
  // sit beside the map's tree.
  const std::vector<float> to_map =
      NearestWithin(map_tree, *ToPcl(static_groundtruth), options.completeness_distance);
  const size_t covered = static_cast<size_t>(
      std::count_if(to_map.begin(), to_map.end(), [](float d) { return !std::isinf(d); }));
  quality.completeness = static_cast<double>(covered) / static_cast<double>(to_map.size());
  return quality;
}

}  // namespace stillmap
