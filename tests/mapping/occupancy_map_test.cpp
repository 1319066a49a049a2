#include "stillmap/mapping/occupancy_map.h"

#include <gtest/gtest.h>
#include <octomap/OcTree.h>

#include <Eigen/Geometry>
#include <iostream>
#include <memory>

#include "stillmap/io/error.h"
#include "test_util.h"

namespace stillmap {
namespace {

// A 1 m x 1 m wall at z = 2 m, sampled every 1 cm, seen from the origin.
std::vector<Eigen::Vector3f> Wall() {
  std::vector<Eigen::Vector3f> points;
  for (int i = -50; i <= 50; ++i) {
    for (int j = -50; j <= 50; ++j) points.emplace_back(0.01f * i, 0.01f * j, 2.0f);
  }
  return points;
}

TEST(OccupancyMapTest, RayCastingMarksHitsOccupiedAndTheWayFree) {
  OccupancyMap map;  // 5 cm
  for (int k = 0; k < 3; ++k) map.InsertScan(Wall(), Eigen::Vector3f::Zero());
  EXPECT_GT(map.Occupancy({0.0, 0.0, 2.0}), 0.5);
  EXPECT_GT(map.Occupancy({0.3, -0.3, 2.01}), 0.5);
  EXPECT_LT(map.Occupancy({0.0, 0.0, 1.0}), 0.5);  // seen through: free
  EXPECT_GE(map.Occupancy({0.0, 0.0, 1.0}), 0.0);  // and known
  EXPECT_LT(map.Occupancy({0.0, 0.0, 3.0}), 0.0);  // behind the wall: unknown
  EXPECT_LT(map.Occupancy({2.0, 0.0, 1.0}), 0.0);  // outside the view: unknown
  EXPECT_GT(map.OccupiedLeafCount(), 300u);
}

// A wall seen at z = 2 m by an earlier session and gone in a later one (seen through to z = 3 m):
// where the later session is decisive its value replaces the earlier; where it is not, the
// evidence adds up. Checked against the log-odds of OctoMap's sensor model.
TEST(OccupancyMapTest, OverlayLetsADecisiveLaterSessionWin) {
  std::vector<Eigen::Vector3f> far_wall = Wall();
  for (Eigen::Vector3f& point : far_wall) point.z() = 3.0f;
  auto scanned = [](const std::vector<Eigen::Vector3f>& points, int times) {
    OccupancyMap map;
    for (int k = 0; k < times; ++k) map.InsertScan(points, Eigen::Vector3f::Zero());
    return map;
  };
  const double decisive = OccupancyMapOptions{}.DecisiveLogOdds();
  EXPECT_NEAR(decisive, 2.0 * std::log(0.7 / 0.3), 1e-12);  // two hits' weight
  const double clamped = std::log(0.971 / 0.029), miss = std::log(0.4 / 0.6);

  OccupancyMap a = scanned(Wall(), 10);
  ASSERT_NEAR(a.Occupancy({0.0, 0.0, 2.0}), 0.971, 1e-3);
  a.Overlay(scanned(far_wall, 5), decisive);  // five misses (-2.0 after clamping): decisive
  EXPECT_NEAR(a.Occupancy({0.0, 0.0, 2.0}), 0.1192, 1e-3);
  EXPECT_GT(a.Occupancy({0.0, 0.0, 3.0}), 0.5);  // the new wall stands
  EXPECT_LT(a.Occupancy({0.0, 0.0, 3.5}), 0.0);  // behind it nothing is known
  EXPECT_LT(a.Occupancy({2.0, 0.0, 1.0}), 0.0);  // nor outside both views

  OccupancyMap b = scanned(Wall(), 10);
  b.Overlay(scanned(far_wall, 3), decisive);  // three misses (-1.22): not decisive, they add up
  EXPECT_NEAR(b.Occupancy({0.0, 0.0, 2.0}), 1.0 / (1.0 + std::exp(-(clamped + 3 * miss))), 1e-3);
}

TEST(OccupancyMapTest, MaxRangeTruncatesRaysWithoutHits) {
  OccupancyMapOptions options;
  options.max_range = 1.0;
  OccupancyMap map(options);
  map.InsertScan(Wall(), Eigen::Vector3f::Zero());
  EXPECT_LT(map.Occupancy({0.0, 0.0, 2.0}), 0.0);  // beyond range: not inserted
  EXPECT_LT(map.Occupancy({0.0, 0.0, 0.5}), 0.5);  // free up to the range
  EXPECT_GE(map.Occupancy({0.0, 0.0, 0.5}), 0.0);
}

// Moved into another frame (turned 30 degrees about a tilted axis and shifted), the map holds
// what the old one held at the corresponding points: the wall occupied, the space in front free,
// behind it unknown; the known volume is kept within a few per cent (nearest-neighbour
// resampling leaves no holes).
TEST(OccupancyMapTest, TransformedMapHoldsTheSameSpace) {
  OccupancyMap map;
  for (int k = 0; k < 3; ++k) map.InsertScan(Wall(), Eigen::Vector3f::Zero());
  Eigen::Isometry3d new_from_old = Eigen::Isometry3d::Identity();
  new_from_old.linear() = Eigen::AngleAxisd(0.52, Eigen::Vector3d(1, 2, 3).normalized()).matrix();
  new_from_old.translation() = Eigen::Vector3d(0.4, -1.3, 0.7);
  const OccupancyMap moved = map.Transformed(new_from_old);
  // The wall, every 1 cm across it, inside its voxel layer (z 2.0 to 2.05): no hole.
  for (int i = -40; i <= 40; ++i) {
    for (int j = -40; j <= 40; ++j) {
      const Eigen::Vector3d p(0.01 * i, 0.01 * j, 2.025);
      ASSERT_GT(moved.Occupancy(new_from_old * p), 0.5) << p.transpose();
    }
  }
  for (const Eigen::Vector3d& p :
       {Eigen::Vector3d(0.0, 0.0, 1.0), Eigen::Vector3d(0.1, 0.2, 1.5)}) {
    EXPECT_LT(moved.Occupancy(new_from_old * p), 0.5) << p.transpose();
    EXPECT_GE(moved.Occupancy(new_from_old * p), 0.0) << p.transpose();
  }
  EXPECT_LT(moved.Occupancy(new_from_old * Eigen::Vector3d(0.0, 0.0, 3.0)), 0.0);
  EXPECT_LT(moved.Occupancy(new_from_old * Eigen::Vector3d(2.0, 0.0, 1.0)), 0.0);
  auto volume = [](const OccupancyMap& m, bool occupied_only) {
    double sum = 0.0;
    m.ForEachLeaf([&](const Eigen::Vector3d&, double size, bool occupied) {
      if (occupied || !occupied_only) sum += size * size * size;
    });
    return sum;
  };
  EXPECT_NEAR(volume(moved, false), volume(map, false), 0.05 * volume(map, false));
  // The wall, one voxel thick, comes out 1.5 voxels thick on average (grown by a quarter each
  // side).
  std::cout << "occupied volume " << volume(map, true) << " m^3, moved " << volume(moved, true)
            << " m^3\n";
  EXPECT_GT(volume(moved, true), 1.2 * volume(map, true));
  EXPECT_LT(volume(moved, true), 2.0 * volume(map, true));
  // Identity: the same tree.
  const OccupancyMap same = map.Transformed(Eigen::Isometry3d::Identity());
  EXPECT_EQ(same.LeafCount(), map.LeafCount());
  EXPECT_EQ(same.OccupiedLeafCount(), map.OccupiedLeafCount());
}

TEST(OccupancyMapTest, BinaryAndFullFilesReadBackInOctoMap) {
  testing::TempDir dir;
  OccupancyMap map;
  map.InsertScan(Wall(), Eigen::Vector3f::Zero());
  map.WriteBinary(dir / "map.bt");
  map.WriteFull(dir / "map.ot");
  octomap::OcTree binary(0.1);
  ASSERT_TRUE(binary.readBinary(dir / "map.bt"));
  EXPECT_DOUBLE_EQ(binary.getResolution(), 0.05);
  const octomap::OcTreeNode* hit = binary.search(0.0, 0.0, 2.0);
  ASSERT_NE(hit, nullptr);
  EXPECT_TRUE(binary.isNodeOccupied(hit));
  std::unique_ptr<octomap::AbstractOcTree> full(octomap::AbstractOcTree::read(dir / "map.ot"));
  ASSERT_NE(full, nullptr);
  EXPECT_EQ(full->getTreeType(), "OcTree");
  EXPECT_EQ(full->size(), binary.size());
}

// Both files as octomap-tools' convert_octree reads them (what octovis and octomap_server load):
// it converts each to .ot, and the converted tree has the same nodes and the wall occupied.
TEST(OccupancyMapTest, ConvertOctreeReadsBothFiles) {
  std::string output;
  ASSERT_EQ(testing::RunCommand("command -v convert_octree", &output), 0)
      << "convert_octree not found: install Debian's octomap-tools (scripts/setup.sh does)";
  testing::TempDir dir;
  OccupancyMap map;
  for (int k = 0; k < 2; ++k) map.InsertScan(Wall(), Eigen::Vector3f::Zero());
  Eigen::Isometry3d turned = Eigen::Isometry3d::Identity();
  turned.linear() = Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitX()).matrix();
  const OccupancyMap moved = map.Transformed(turned);
  moved.WriteBinary(dir / "map.bt");
  moved.WriteFull(dir / "map.ot");
  for (const char* name : {"map.bt", "map.ot"}) {
    const std::string converted = dir / (std::string(name) + ".converted.ot");
    ASSERT_EQ(testing::RunCommand("convert_octree " + dir / name + " " + converted, &output), 0)
        << output;
    std::unique_ptr<octomap::AbstractOcTree> tree(octomap::AbstractOcTree::read(converted));
    ASSERT_NE(tree, nullptr) << name;
    auto* octree = dynamic_cast<octomap::OcTree*>(tree.get());
    ASSERT_NE(octree, nullptr) << name;
    EXPECT_EQ(octree->getNumLeafNodes(), moved.LeafCount()) << name;
    const Eigen::Vector3d wall = turned * Eigen::Vector3d(0.1, -0.2, 2.025);
    const octomap::OcTreeNode* hit = octree->search(wall.x(), wall.y(), wall.z());
    ASSERT_NE(hit, nullptr) << name;
    EXPECT_TRUE(octree->isNodeOccupied(hit)) << name;
  }
}

TEST(OccupancyMapTest, ImpossibleOptionsAreRejected) {
  OccupancyMapOptions options;
  options.resolution = 0.0;
  EXPECT_THROW(options.Validate(), InputError);
  options = {};
  options.probability_hit = 0.3;
  EXPECT_THROW(options.Validate(), InputError);
}

// OctoMap's 16-bit keys reach +-32767 leaves: points (or a whole scan whose origin lies) beyond
// are counted and left out instead of flooding stderr with "out of OcTree bounds".
TEST(OccupancyMapTest, PointsBeyondTheExtentAreCountedAndLeftOut) {
  OccupancyMapOptions options;
  options.resolution = 0.05;
  OccupancyMap map(options);
  EXPECT_NEAR(map.extent(), 1638.35, 1e-9);
  map.InsertScan({Eigen::Vector3f(1, 0, 2), Eigen::Vector3f(1e4f, 0, 2)}, Eigen::Vector3f::Zero());
  EXPECT_EQ(map.rejected_count(), 1u);
  EXPECT_GT(map.Occupancy(Eigen::Vector3d(1, 0, 2)), 0.5);
  EXPECT_LT(map.Occupancy(Eigen::Vector3d(1e4, 0, 2)), 0.0);  // unknown, and no error printed
  map.InsertScan({Eigen::Vector3f(2e3f, 0, 2)}, Eigen::Vector3f(2e3f, 0, 0));
  EXPECT_EQ(map.rejected_count(), 2u);
}
}  // namespace
}  // namespace stillmap
