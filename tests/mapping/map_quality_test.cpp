#include "stillmap/mapping/map_quality.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

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

TEST(MapQualityTest, TheMapIsCarriedIntoTheTruthsFrame) {
  // The same partial map, given in a frame turned and moved away from the truth's, with the
  // transform back: the same figures as the map given in the truth's frame.
  const std::vector<VoxelPoint> groundtruth = Grid(0.0f, 2.0f, 0.01f);
  const std::vector<VoxelPoint> map = Grid(0.003f, 1.0f, 0.01f);
  Eigen::Isometry3f map_from_truth = Eigen::Isometry3f::Identity();
  map_from_truth.rotate(Eigen::AngleAxisf(0.7f, Eigen::Vector3f(1, 2, 3).normalized()));
  map_from_truth.pretranslate(Eigen::Vector3f(12.0f, -4.0f, 2.5f));
  std::vector<VoxelPoint> moved = map;
  for (VoxelPoint& point : moved) point.position = map_from_truth * point.position;
  const MapQuality direct = EvaluateMap(map, groundtruth);
  const MapQuality carried = EvaluateMap(moved, groundtruth, {}, map_from_truth.inverse());
  EXPECT_NEAR(carried.accuracy_median, direct.accuracy_median, 1e-5);
  EXPECT_NEAR(carried.completeness, direct.completeness, 1e-3);
  EXPECT_NEAR(carried.on_surface_share, 1.0, 1e-9);
  EXPECT_NEAR(carried.ghost_share, 0.0, 1e-9);
}

TEST(MapQualityTest, ShareFiguresAreThoseOfAnExhaustiveSearch) {
  // Scattered points around and across cell boundaries (negative coordinates, one point far
  // beyond the cells' range): every share and the median as a search of all pairs finds them.
  std::mt19937 random(7);
  std::uniform_real_distribution<float> coordinate(-0.3f, 0.3f);
  auto scatter = [&](size_t count) {
    std::vector<VoxelPoint> points(count);
    for (VoxelPoint& point : points) {
      point.position = Eigen::Vector3f(coordinate(random), coordinate(random), coordinate(random));
    }
    return points;
  };
  const std::vector<VoxelPoint> groundtruth = scatter(1500);
  std::vector<VoxelPoint> map = scatter(1000);
  map.push_back(VoxelPoint{Eigen::Vector3f(1.0e6f, -2.0e6f, 3.0f), {}, 1});
  auto nearest = [](const Eigen::Vector3f& q, const std::vector<VoxelPoint>& data) {
    float best = std::numeric_limits<float>::infinity();
    for (const VoxelPoint& p : data) best = std::min(best, (p.position - q).norm());
    return best;
  };
  size_t on_surface = 0, ghosts = 0, covered = 0;
  std::vector<float> within;  // the map's distances up to the ghost distance
  for (const VoxelPoint& point : map) {
    const float d = nearest(point.position, groundtruth);
    on_surface += d <= 0.03f ? 1 : 0;
    ghosts += d > 0.05f ? 1 : 0;
    if (d <= 0.05f) within.push_back(d);
  }
  for (const VoxelPoint& point : groundtruth) covered += nearest(point.position, map) <= 0.05f;
  const MapQuality quality = EvaluateMap(map, groundtruth);
  const double count = static_cast<double>(map.size());
  EXPECT_DOUBLE_EQ(quality.on_surface_share, static_cast<double>(on_surface) / count);
  EXPECT_DOUBLE_EQ(quality.ghost_share, static_cast<double>(ghosts) / count);
  EXPECT_DOUBLE_EQ(quality.completeness,
                   static_cast<double>(covered) / static_cast<double>(groundtruth.size()));
  ASSERT_LT(ghosts * 2, map.size());  // the median is then one of the distances within
  std::vector<float> all = within;
  all.resize(map.size(), std::numeric_limits<float>::max());
  std::nth_element(all.begin(), all.begin() + all.size() / 2, all.end());
  EXPECT_NEAR(quality.accuracy_median, all[all.size() / 2], 1e-6);
}

}  // namespace
}  // namespace stillmap
