#include "stillmap/mapping/voxel_cloud.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <random>
#include <tuple>
#include <utility>

#include "stillmap/io/error.h"

namespace stillmap {
namespace {

ColoredPoints MakePoints(const std::vector<Eigen::Vector3f>& positions, std::uint8_t gray = 100) {
  ColoredPoints points;
  for (const auto& p : positions) {
    points.positions.push_back(p);
    points.colors.push_back({gray, gray, gray});
  }
  return points;
}

TEST(VoxelCloudTest, PointsOfOneVoxelAverage) {
  VoxelCloud cloud;  // 1 cm
  ColoredPoints points = MakePoints({{0.001f, 0.002f, 0.003f}, {0.009f, 0.008f, 0.007f}});
  points.colors[0] = {0, 100, 200};
  points.colors[1] = {10, 110, 210};
  cloud.Insert(points);
  ASSERT_EQ(cloud.size(), 1u);
  const VoxelPoint p = cloud.Points()[0];
  EXPECT_NEAR(p.position.x(), 0.005f, 1e-6);
  EXPECT_NEAR(p.position.y(), 0.005f, 1e-6);
  EXPECT_EQ(p.rgb, (std::array<std::uint8_t, 3>{5, 105, 205}));
  EXPECT_EQ(p.count, 2u);
}

TEST(VoxelCloudTest, RemovedVoxelsLeaveTheOutputAndStartAfreshWhenSeenAgain) {
  VoxelCloud cloud;  // 1 cm
  std::vector<Eigen::Vector3f> positions(10, Eigen::Vector3f::Zero());
  for (int i = 0; i < 10; ++i)
    positions[static_cast<size_t>(i)].x() = 0.01f * static_cast<float>(i) + 0.005f;
  cloud.Insert(MakePoints(positions, 100));
  ASSERT_EQ(cloud.size(), 10u);
  // Points come sorted by key: the x index runs 0..9, so the first three are x < 0.03.
  std::vector<float> seen;
  const size_t removed = cloud.RemoveIf([&seen](const VoxelPoint& p) {
    seen.push_back(p.position.x());
    return p.position.x() < 0.03f;
  });
  EXPECT_EQ(removed, 3u);
  EXPECT_TRUE(std::is_sorted(seen.begin(), seen.end()));
  EXPECT_EQ(cloud.size(), 7u);
  EXPECT_EQ(cloud.OutputSize(), 7u);
  for (const VoxelPoint& p : cloud.Points()) EXPECT_GE(p.position.x(), 0.03f);
  // A removed voxel seen again holds only its new points.
  cloud.Insert(MakePoints({{0.001f, 0.0f, 0.0f}}, 200));
  EXPECT_EQ(cloud.size(), 8u);
  const VoxelPoint first = cloud.Points().front();
  EXPECT_EQ(first.count, 1u);
  EXPECT_NEAR(first.position.x(), 0.001f, 1e-6);
  EXPECT_EQ(first.rgb[0], 200);
}

TEST(VoxelCloudTest, NegativeCoordinatesFloorIntoTheirOwnVoxel) {
  VoxelCloud cloud;
  cloud.Insert(MakePoints({{-0.001f, 0.0f, 0.0f}, {0.001f, 0.0f, 0.0f}}));
  EXPECT_EQ(cloud.size(), 2u);
}

TEST(VoxelCloudTest, MatchesAReferenceMapOnRandomPoints) {
  // 300k points over a 6 m room at 2 cm: the table grows many times; every voxel's count and
  // centroid must equal an independent std::map computation.
  VoxelCloudOptions options;
  options.leaf_size = 0.02;
  VoxelCloud cloud(options);
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> coordinate(-3.0f, 3.0f);
  std::vector<Eigen::Vector3f> positions;
  positions.reserve(300000);
  for (int i = 0; i < 300000; ++i) {
    positions.emplace_back(coordinate(rng), coordinate(rng), 0.5f * coordinate(rng));
  }
  cloud.Insert(MakePoints(positions));
  std::map<std::tuple<long, long, long>, std::pair<Eigen::Vector3d, int>> reference;
  for (const auto& p : positions) {
    const auto key = std::make_tuple(static_cast<long>(std::floor(p.x() / 0.02)),
                                     static_cast<long>(std::floor(p.y() / 0.02)),
                                     static_cast<long>(std::floor(p.z() / 0.02)));
    auto [it, inserted] = reference.try_emplace(key, Eigen::Vector3d::Zero(), 0);
    auto& entry = it->second;
    entry.first += p.cast<double>();
    ++entry.second;
  }
  ASSERT_EQ(cloud.size(), reference.size());
  // Points() is sorted by voxel key, i.e. by (ix, iy, iz) as the reference map.
  const std::vector<VoxelPoint> points = cloud.Points();
  auto it = reference.begin();
  for (const VoxelPoint& p : points) {
    EXPECT_EQ(static_cast<int>(p.count), it->second.second);
    EXPECT_LT((p.position.cast<double>() - it->second.first / it->second.second).norm(), 1e-5);
    ++it;
  }
}

TEST(VoxelCloudTest, ACloudClearedHandsItsTableBackAndFilledAgainEqualsANewOne) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> coordinate(-2.0f, 2.0f);
  auto random_points = [&](int n) {
    std::vector<Eigen::Vector3f> positions;
    positions.reserve(static_cast<size_t>(n));
    for (int i = 0; i < n; ++i) positions.emplace_back(coordinate(rng), coordinate(rng), 0.0f);
    return MakePoints(positions);
  };
  const ColoredPoints before = random_points(200000), after = random_points(50000);
  VoxelCloud cloud;
  cloud.Insert(before);
  cloud.Insert(MakePoints({{20000.0f, 0.0f, 0.0f}}));
  cloud.RemoveIf([](const VoxelPoint& p) { return p.position.x() < 0.0f; });
  const size_t table = cloud.MemoryBytes();
  cloud.Clear();
  EXPECT_EQ(cloud.size(), 0u);
  EXPECT_EQ(cloud.rejected_count(), 0u);
  EXPECT_TRUE(cloud.Points().empty());
  EXPECT_EQ(cloud.MemoryBytes(), VoxelCloud().MemoryBytes());
  EXPECT_LT(cloud.MemoryBytes(), table / 10);
  cloud.Insert(after);
  VoxelCloud fresh;
  fresh.Insert(after);
  const std::vector<VoxelPoint> a = cloud.Points(), b = fresh.Points();
  ASSERT_EQ(a.size(), b.size());
  for (size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].position, b[i].position);
    EXPECT_EQ(a[i].rgb, b[i].rgb);
    EXPECT_EQ(a[i].count, b[i].count);
  }
  EXPECT_EQ(cloud.MemoryBytes(), fresh.MemoryBytes());
}

// Taken out, the points are those Points() gives (removed voxels and min_points kept out), and the
// cloud is a new one: empty, its table back to its first size, and filled again as a new one.
TEST(VoxelCloudTest, TakenPointsAreThePointsAndLeaveANewCloud) {
  std::mt19937 rng(12);
  std::uniform_real_distribution<float> coordinate(-1.0f, 1.0f);
  std::vector<Eigen::Vector3f> positions;
  positions.reserve(100000);
  for (int i = 0; i < 100000; ++i) positions.emplace_back(coordinate(rng), coordinate(rng), 0.0f);
  VoxelCloudOptions options;
  options.min_points = 2;
  VoxelCloud cloud(options);
  cloud.Insert(MakePoints(positions));
  cloud.RemoveIf([](const VoxelPoint& p) { return p.position.y() < -0.5f; });
  const std::vector<VoxelPoint> expected = cloud.Points();
  ASSERT_GT(expected.size(), 1000u);
  const std::vector<VoxelPoint> taken = cloud.TakePoints();
  ASSERT_EQ(taken.size(), expected.size());
  for (size_t i = 0; i < taken.size(); ++i) {
    EXPECT_EQ(taken[i].position, expected[i].position);
    EXPECT_EQ(taken[i].rgb, expected[i].rgb);
    EXPECT_EQ(taken[i].count, expected[i].count);
  }
  EXPECT_EQ(cloud.size(), 0u);
  EXPECT_EQ(cloud.MemoryBytes(), VoxelCloud(options).MemoryBytes());
  const ColoredPoints again = MakePoints({{0.001f, 0.0f, 0.0f}, {0.002f, 0.0f, 0.0f}});
  cloud.Insert(again);
  ASSERT_EQ(cloud.Points().size(), 1u);  // min_points kept: two points in one voxel
  EXPECT_EQ(cloud.Points()[0].count, 2u);
}

// The key order made by a removal serves the visits after it, which skip what later removals took,
// until points come in: then new voxels, and removed ones seen again, take their places in it.
TEST(VoxelCloudTest, VisitsAfterRemovalsAndInsertionsFollowTheKeyOrder) {
  const auto centre = [](int i, int j) {
    return Eigen::Vector3f(0.01f * static_cast<float>(i) + 0.005f,
                           0.01f * static_cast<float>(j) + 0.005f, 0.005f);
  };
  const auto index = [](const Eigen::Vector3f& p) {  // (i, j) of a voxel's centroid
    return std::make_pair(static_cast<int>(std::floor(p.x() / 0.01f)),
                          static_cast<int>(std::floor(p.y() / 0.01f)));
  };
  std::vector<Eigen::Vector3f> grid;
  for (int i = -10; i < 10; ++i) {
    for (int j = -10; j < 10; ++j) grid.push_back(centre(i, j));
  }
  VoxelCloud cloud;
  cloud.Insert(MakePoints(grid));
  EXPECT_EQ(cloud.RemoveIf([](const VoxelPoint& p) { return p.position.x() < 0.0f; }), 200u);
  EXPECT_EQ(cloud.RemoveIf([](const VoxelPoint& p) { return p.position.y() < 0.0f; }), 100u);
  std::vector<std::pair<int, int>> expected;  // in key order: i, then j
  for (int i = 0; i < 10; ++i) {
    for (int j = 0; j < 10; ++j) expected.emplace_back(i, j);
  }
  const auto visited = [&cloud, &index] {
    std::vector<std::pair<int, int>> out;
    cloud.ForEachPoint([&](const VoxelPoint& p) { out.push_back(index(p.position)); });
    return out;
  };
  EXPECT_EQ(visited(), expected);
  // The kept order holds at least 5 bytes a voxel left, beside the table; the table's own figure
  // leaves it out, and insertions drop it.
  EXPECT_GE(cloud.MemoryBytes() - cloud.TableBytes(), 5u * 100);
  cloud.Insert(MakePoints({centre(-3, 0), centre(12, 5), centre(4, -2)}));
  EXPECT_EQ(cloud.MemoryBytes(), cloud.TableBytes());
  expected.insert(expected.begin(), {-3, 0});
  expected.insert(expected.begin() + 41, {4, -2});  // after (-3, 0) and i = 0..3
  expected.emplace_back(12, 5);
  EXPECT_EQ(visited(), expected);
  const std::vector<VoxelPoint> taken = cloud.TakePoints();
  ASSERT_EQ(taken.size(), expected.size());
  for (size_t k = 0; k < taken.size(); ++k) EXPECT_EQ(index(taken[k].position), expected[k]);
}

// Past 2^14 points a shard TakePoints makes each shard's points in several parts before merging
// them: 1.5 M voxels (about 23000 a shard) still come out as Points() gives them, in key order.
TEST(VoxelCloudTest, TakenPointsOfManyVoxelsKeepTheKeyOrder) {
  std::vector<Eigen::Vector3f> positions;
  positions.reserve(size_t{1225} * 1225);
  for (int i = 0; i < 1225; ++i) {
    for (int j = 0; j < 1225; ++j) {  // voxel centres
      positions.emplace_back(static_cast<float>((i + 0.5) * 0.01),
                             static_cast<float>((j - 600 + 0.5) * 0.01), 1.005f);
    }
  }
  VoxelCloud cloud;
  cloud.Insert(MakePoints(positions));
  const std::vector<VoxelPoint> expected = cloud.Points();
  ASSERT_EQ(expected.size(), positions.size());
  const std::vector<VoxelPoint> taken = cloud.TakePoints();
  ASSERT_EQ(taken.size(), expected.size());
  size_t differing = 0;
  for (size_t i = 0; i < taken.size(); ++i) differing += taken[i].position != expected[i].position;
  EXPECT_EQ(differing, 0u);
  // Key order: x, then y, then z.
  EXPECT_LT(taken.front().position.x(), 0.01f);
  EXPECT_LT(taken.front().position.y(), -5.99f);
  EXPECT_GT(taken.back().position.x(), 12.2f);
  EXPECT_GT(taken.back().position.y(), 6.2f);
}

// 36 bytes of sums a voxel and a 4-byte index entry at a load of 0.375 to 0.75: under 50 bytes a
// voxel from half a million on (a table of 40-byte slots took 53 to 107; a small cloud holds
// part of a 2048-record page per shard).
TEST(VoxelCloudTest, AVoxelCostsUnderFiftyBytes) {
  for (const int side : {700, 1400}) {  // 490 k and 1.96 M voxels on a plane
    std::vector<Eigen::Vector3f> positions;
    for (int i = 0; i < side; ++i) {
      for (int j = 0; j < side; ++j) {
        positions.emplace_back(0.01f * i + 0.005f, 0.01f * j + 0.005f, 0.5f);
      }
    }
    VoxelCloud cloud;  // 1 cm
    cloud.Insert(MakePoints(positions));
    ASSERT_EQ(cloud.size(), static_cast<size_t>(side) * side);
    EXPECT_LT(static_cast<double>(cloud.MemoryBytes()) / static_cast<double>(cloud.size()), 50.0)
        << side * side << " voxels";
  }
}

TEST(VoxelCloudTest, PointsBeyondTheKeyRangeAreCountedNotWrapped) {
  VoxelCloud cloud;
  cloud.Insert(MakePoints({{20000.0f, 0.0f, 0.0f}, {1.0f, 1.0f, 1.0f}}));
  EXPECT_EQ(cloud.size(), 1u);
  EXPECT_EQ(cloud.rejected_count(), 1u);
}

TEST(VoxelCloudTest, ImpossibleLeafIsRejected) {
  VoxelCloudOptions options;
  options.leaf_size = 0.0;
  EXPECT_THROW(VoxelCloud{options}, InputError);
}

}  // namespace
}  // namespace stillmap
