#include "stillmap/mapping/map_quality.h"

#include <pcl/kdtree/kdtree_flann.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <thread>
#include <utility>
#include <vector>

#include "cell_grid.h"

namespace stillmap {
namespace {

pcl::PointCloud<pcl::PointXYZ>::Ptr ToPcl(const std::vector<VoxelPoint>& points) {
  pcl::PointCloud<pcl::PointXYZ>::Ptr cloud(new pcl::PointCloud<pcl::PointXYZ>);
  cloud->resize(points.size());
  for (size_t i = 0; i < points.size(); ++i) (*cloud)[i].getVector3fMap() = points[i].position;
  return cloud;
}

// Runs work(begin, end) over [0, count) on two threads, the first half on a helper.
template <typename Work>
void OnTwoThreads(size_t count, Work work) {
  std::thread helper(work, size_t{0}, count / 2);
  work(count / 2, count);
  helper.join();
}

// For every point of `queries` (in its grid's order), the distance to its nearest point of `data`
// if one lies within `radius` (at most the grids' edge), else +infinity. Two threads.
std::vector<float> NearestWithin(const CellGrid& queries, const CellGrid& data, float radius) {
  std::vector<float> distances(queries.points().size());
  const float radius_squared = radius * radius;
  OnTwoThreads(queries.cells(), [&](size_t begin, size_t end) {
    std::vector<std::pair<const Eigen::Vector3f*, const Eigen::Vector3f*>> near;
    for (size_t cell = begin; cell < end; ++cell) {
      near.clear();
      queries.ForNeighbours(data, cell,
                            [&](const Eigen::Vector3f* first, const Eigen::Vector3f* last) {
                              near.emplace_back(first, last);
                            });
      for (const Eigen::Vector3f* q = queries.begin(cell); q != queries.end(cell); ++q) {
        float best = std::numeric_limits<float>::infinity();
        for (const auto& [first, last] : near) {
          for (const Eigen::Vector3f* p = first; p != last; ++p) {
            const float dx = q->x() - p->x(), dy = q->y() - p->y(), dz = q->z() - p->z();
            best = std::min(best, dx * dx + dy * dy + dz * dz);
          }
        }
        distances[static_cast<size_t>(q - queries.points().data())] =
            best <= radius_squared ? std::sqrt(best) : std::numeric_limits<float>::infinity();
      }
    }
  });
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

// Accuracy and ghosts: the map against the ground truth's grid.
void MeasureAccuracy(const CellGrid& map, const CellGrid& groundtruth,
                     const pcl::PointCloud<pcl::PointXYZ>::Ptr& coarse_groundtruth,
                     const MapQualityOptions& options, MapQuality* quality) {
  std::vector<float> to_groundtruth =
      NearestWithin(map, groundtruth, static_cast<float>(options.ghost_distance));
  // Ghosts (nothing within the radius): their distance to the coarse ground truth.
  pcl::KdTreeFLANN<pcl::PointXYZ> coarse_tree;
  coarse_tree.setInputCloud(coarse_groundtruth);
  std::vector<int> index(1);
  std::vector<float> squared(1);
  size_t ghosts = 0, on_surface = 0;
  double sum = 0.0;
  for (size_t i = 0; i < to_groundtruth.size(); ++i) {
    if (to_groundtruth[i] <= options.surface_distance) ++on_surface;
    if (std::isinf(to_groundtruth[i])) {
      ++ghosts;
      pcl::PointXYZ query;
      query.getVector3fMap() = map.points()[i];
      coarse_tree.nearestKSearch(query, 1, index, squared);
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

std::vector<Eigen::Vector3f> Positions(const std::vector<VoxelPoint>& points,
                                       const Eigen::Isometry3f& transform) {
  std::vector<Eigen::Vector3f> positions;
  positions.reserve(points.size());
  for (const VoxelPoint& point : points) positions.push_back(transform * point.position);
  return positions;
}

}  // namespace

MapQuality EvaluateMap(const std::vector<VoxelPoint>& map,
                       std::vector<VoxelPoint> static_groundtruth, const MapQualityOptions& options,
                       const Eigen::Isometry3f& groundtruth_from_map) {
  MapQuality quality;
  quality.map_points = map.size();
  quality.groundtruth_points = static_groundtruth.size();
  if (map.empty() || static_groundtruth.empty()) return quality;
  // One edge for both grids: every search radius fits in it. The truth's points go once its
  // grid and coarse copy are made.
  const auto edge =
      static_cast<float>(std::max(options.ghost_distance, options.completeness_distance));
  const pcl::PointCloud<pcl::PointXYZ>::Ptr coarse = CoarseCloud(static_groundtruth);
  const CellGrid groundtruth_grid(Positions(static_groundtruth, Eigen::Isometry3f::Identity()),
                                  edge);
  std::vector<VoxelPoint>().swap(static_groundtruth);
  const CellGrid map_grid(Positions(map, groundtruth_from_map), edge);
  MeasureAccuracy(map_grid, groundtruth_grid, coarse, options, &quality);
  const std::vector<float> to_map =
      NearestWithin(groundtruth_grid, map_grid, static_cast<float>(options.completeness_distance));
  const size_t covered = static_cast<size_t>(
      std::count_if(to_map.begin(), to_map.end(), [](float d) { return !std::isinf(d); }));
  quality.completeness = static_cast<double>(covered) / static_cast<double>(to_map.size());
  return quality;
}

}  // namespace stillmap
