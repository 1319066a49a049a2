#include "stillmap/mapping/map_cleaning.h"

#include <gtest/gtest.h>

#include <vector>

#include "stillmap/io/error.h"

namespace stillmap {
namespace {

// Scans of a 1 m x 1 m wall at z = 2 m (every 1 cm) from the origin. In the first scan a
// "person", a 20 cm x 20 cm patch at z = 1 m, hides part of the wall; the later scans see the
// wall through where it stood.
struct Scene {
  std::vector<Eigen::Vector3f> wall;
  std::vector<Eigen::Vector3f> person;
  std::vector<Eigen::Vector3f> first_scan;
};

Scene MakeScene() {
  Scene scene;
  for (int i = -50; i < 50; ++i) {
    for (int j = -50; j < 50; ++j) {
      const Eigen::Vector3f wall(0.01f * static_cast<float>(i) + 0.005f,
                                 0.01f * static_cast<float>(j) + 0.005f, 2.0f);
      scene.wall.push_back(wall);
      if (i >= 0 && i < 20 && j >= 0 && j < 20) {
        scene.person.push_back(wall * 0.5f);  // the same ray, half way
        scene.first_scan.push_back(wall * 0.5f);
      } else {
        scene.first_scan.push_back(wall);
      }
    }
  }
  return scene;
}

ColoredPoints Colored(const std::vector<Eigen::Vector3f>& positions) {
  ColoredPoints points;
  points.positions = positions;
  points.colors.assign(positions.size(), {100, 100, 100});
  return points;
}

TEST(MapCleaningTest, VoxelsSeenThroughLaterAreRemovedAndTheWallKept) {
  const Scene scene = MakeScene();
  OccupancyMap occupancy;  // 5 cm
  occupancy.InsertScan(scene.first_scan, Eigen::Vector3f::Zero());
  for (int k = 0; k < 3; ++k) occupancy.InsertScan(scene.wall, Eigen::Vector3f::Zero());
  VoxelCloud cloud;  // 1 cm: one voxel per wall point; the person, half as far, fills 10 x 10
  cloud.Insert(Colored(scene.wall));
  cloud.Insert(Colored(scene.person));
  const size_t person_voxels = 100;
  ASSERT_EQ(cloud.size(), scene.wall.size() + person_voxels);

  MapCleaningOptions options;
  const MapCleaningResult result = CleanCloud(options, &occupancy, &cloud);
  EXPECT_EQ(result.seen_through, person_voxels);
  EXPECT_EQ(result.outliers, 0u);
  EXPECT_EQ(cloud.size(), scene.wall.size());
  for (const VoxelPoint& p : cloud.Points()) EXPECT_NEAR(p.position.z(), 2.0f, 1e-4);

  // Switched off, or without an OctoMap, nothing goes.
  VoxelCloud kept;
  kept.Insert(Colored(scene.wall));
  kept.Insert(Colored(scene.person));
  options.clear_seen_through = false;
  EXPECT_EQ(CleanCloud(options, &occupancy, &kept).seen_through, 0u);
  options.clear_seen_through = true;
  EXPECT_EQ(CleanCloud(options, nullptr, &kept).seen_through, 0u);
  EXPECT_EQ(kept.size(), scene.wall.size() + person_voxels);
}

TEST(MapCleaningTest, StatisticalOutliersAreRemovedFromAPlane) {
  const Scene scene = MakeScene();
  VoxelCloud cloud;
  cloud.Insert(Colored(scene.wall));
  // Five isolated specks, each 30 cm in front of the wall and far from each other.
  const std::vector<Eigen::Vector3f> specks = {{-0.4f, -0.4f, 1.7f},
                                               {0.4f, -0.4f, 1.7f},
                                               {0.0f, 0.0f, 1.7f},
                                               {-0.4f, 0.4f, 1.7f},
                                               {0.4f, 0.4f, 1.7f}};
  cloud.Insert(Colored(specks));
  MapCleaningOptions options;
  options.outlier_removal = true;
  const MapCleaningResult result = CleanCloud(options, nullptr, &cloud);
  EXPECT_EQ(result.outliers, specks.size());
  EXPECT_EQ(cloud.size(), scene.wall.size());
  for (const VoxelPoint& p : cloud.Points()) EXPECT_NEAR(p.position.z(), 2.0f, 1e-4);
}

TEST(MapCleaningTest, ImpossibleOptionsAreRejectedByName) {
  MapCleaningOptions options;
  options.outlier_neighbors = 0;
  EXPECT_THROW(
      {
        try {
          options.Validate();
        } catch (const InputError& e) {
          EXPECT_NE(std::string(e.what()).find("mapping.outlier_neighbors"), std::string::npos);
          throw;
        }
      },
      InputError);
  options = {};
  options.outlier_std_ratio = 0.0;
  EXPECT_THROW(options.Validate(), InputError);
}

}  // namespace
}  // namespace stillmap
