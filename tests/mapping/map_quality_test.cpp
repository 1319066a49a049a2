#include "stillmap/mapping/map_quality.h"

#include <gtest/gtest.h>

namespace stillmap {
namespace {

std::vector<VoxelPoint> Grid(float z, float x_max, float step) {
  std::vector<VoxelPoint> points;
  for (float x = 0.0f; x < x_max; x += step) {
    for (float y = 0.0f; y < 1.0f; y += step) {
      VoxelPoint p{};
      p.position = Eigen::Vector3f(x, y, z);
      points.push_back(p);
    }
  }
  return points;
}

TEST(MapQualityTest, FiguresOfAShiftedPartialMapWithGhosts) {
  // Ground truth: the plane z = 0 over 2 m x 1 m. Map: the first metre of it, 3 mm above, plus a
  // "ghost" block 0.5 m above the plane.
  const std::vector<VoxelPoint> groundtruth = Grid(0.0f, 2.0f, 0.01f);
  std::vector<VoxelPoint> map = Grid(0.003f, 1.0f, 0.01f);
  const std::vector<VoxelPoint> ghost = Grid(0.5f, 0.25f, 0.01f);
  map.insert(map.end(), ghost.begin(), ghost.end());
  const MapQuality quality = EvaluateMap(map, groundtruth);
  const double ghost_share = static_cast<double>(ghost.size()) / map.size();
  EXPECT_NEAR(quality.ghost_share, ghost_share, 1e-9);
  EXPECT_NEAR(quality.accuracy_median, 0.003, 1e-5);
  EXPECT_NEAR(quality.accuracy_mean, (1 - ghost_share) * 0.003 + ghost_share * 0.5, 1e-4);
  // Ground truth up to x = 0.99 + 0.05 is within 5 cm of the map: about 52 % of it.
  EXPECT_NEAR(quality.completeness, 0.52, 0.011);
}

TEST(MapQualityTest, PointsBetweenTheSurfaceAndGhostDistancesAreOffTheSurfaceButNotGhosts) {
  // Ground truth: the plane z = 0. Map: a patch 1 cm above it, one 4 cm above (off the 3 cm
  // surface, closer than the 5 cm of a ghost) and one 8 cm above (a ghost).
  const std::vector<VoxelPoint> groundtruth = Grid(0.0f, 2.0f, 0.01f);
  const std::vector<VoxelPoint> near = Grid(0.01f, 0.5f, 0.01f);
  const std::vector<VoxelPoint> off = Grid(0.04f, 0.3f, 0.01f);
  const std::vector<VoxelPoint> ghost = Grid(0.08f, 0.2f, 0.01f);
  std::vector<VoxelPoint> map = near;
  map.insert(map.end(), off.begin(), off.end());
  map.insert(map.end(), ghost.begin(), ghost.end());
  const MapQuality quality = EvaluateMap(map, groundtruth);
  const double total = static_cast<double>(map.size());
  EXPECT_NEAR(quality.on_surface_share, near.size() / total, 1e-9);
  EXPECT_NEAR(quality.ghost_share, ghost.size() / total, 1e-9);
}

}  // namespace
}  // namespace stillmap
