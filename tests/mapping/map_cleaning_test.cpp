#include "stillmap/mapping/map_cleaning.h"

#include <gtest/gtest.h>

#include <cmath>
#include <opencv2/core.hpp>
#include <vector>

#include "stillmap/io/error.h"
#include "test_util.h"

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
  const MapCleaningResult result = CleanCloud(options, &occupancy, {Camera()}, {}, &cloud);
  EXPECT_EQ(result.seen_through, person_voxels);
  EXPECT_EQ(result.outliers, 0u);
  EXPECT_EQ(cloud.size(), scene.wall.size());
  for (const VoxelPoint& p : cloud.Points()) EXPECT_NEAR(p.position.z(), 2.0f, 1e-4);

  // Switched off, or without an OctoMap, nothing goes.
  VoxelCloud kept;
  kept.Insert(Colored(scene.wall));
  kept.Insert(Colored(scene.person));
  options.clear_seen_through = false;
  EXPECT_EQ(CleanCloud(options, &occupancy, {Camera()}, {}, &kept).seen_through, 0u);
  options.clear_seen_through = true;
  EXPECT_EQ(CleanCloud(options, nullptr, {Camera()}, {}, &kept).seen_through, 0u);
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
  const MapCleaningResult result = CleanCloud(options, nullptr, {Camera()}, {}, &cloud);
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
          EXPECT_NE(std::string(e.what()).find("outlier_neighbors"), std::string::npos);
          throw;
        }
      },
      InputError);
  options = {};
  options.outlier_std_ratio = 0.0;
  EXPECT_THROW(options.Validate(), InputError);
  options = {};
  options.min_free_views = 0;
  EXPECT_THROW(options.Validate(), InputError);
  options = {};
  options.free_view_ratio = std::nan("");
  EXPECT_THROW(options.Validate(), InputError);
}

// The view check at the cloud's resolution, against keyframes' depth, without an OctoMap: a
// "shoe" 30 cm before a wall at 3 m, fused from the one keyframe that saw it, is dropped once
// three other keyframes (cameras 30 cm aside) saw the wall through its place; with two of them
// it stays (2 is not more than twice the 1 that saw it). The wall stays whatever the views.
// A wall 3 m ahead of a camera at the origin, and a shoe 0.3 m before it in the first keyframe
// only: that keyframe's points, and views of the wall from three other places beside its own.
struct ShoeScene {
  Camera camera = testing::SmallCamera(160, 120);
  cv::Mat first;
  std::vector<Eigen::Vector3f> wall, shoe_points;
  std::vector<KeyframeView> views;

  cv::Mat WallDepth() const {
    return cv::Mat(camera.height, camera.width, CV_32FC1, cv::Scalar(3.0f));
  }
  static Eigen::Isometry3d At(float x, float y, float z) {
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.translation() = Eigen::Vector3d(x, y, z);
    return pose;
  }
  ShoeScene() {
    const cv::Rect shoe(70, 80, 12, 8);
    first = WallDepth();
    first(shoe).setTo(2.7f);
    for (int v = 0; v < camera.height; ++v) {
      for (int u = 0; u < camera.width; ++u) {
        const float z = first.at<float>(v, u);
        const Eigen::Vector3f point(static_cast<float>((u - camera.cx) / camera.fx) * z,
                                    static_cast<float>((v - camera.cy) / camera.fy) * z, z);
        (shoe.contains(cv::Point(u, v)) ? shoe_points : wall).push_back(point);
      }
    }
    views = {MakeKeyframeView(first, cv::Mat(), At(0, 0, 0)),
             MakeKeyframeView(WallDepth(), cv::Mat(), At(0.3f, 0, 0)),
             MakeKeyframeView(WallDepth(), cv::Mat(), At(-0.3f, 0, 0)),
             MakeKeyframeView(WallDepth(), cv::Mat(), At(0, 0.3f, 0))};
  }
  VoxelCloud Cloud() const {
    VoxelCloud cloud;
    cloud.Insert(Colored(wall));
    cloud.Insert(Colored(shoe_points));
    return cloud;
  }
  static size_t ShoeVoxels(const VoxelCloud& cloud) {
    size_t count = 0;
    cloud.ForEachPoint([&](const VoxelPoint& point) {
      count += point.position.z() > 2.0f && point.position.z() < 2.8f;
    });
    return count;
  }
};

TEST(MapCleaningTest, VoxelsKeyframesSawThroughAreRemovedAtTheCloudsResolution) {
  const ShoeScene scene;
  const Camera& camera = scene.camera;
  auto wall_depth = [&] { return scene.WallDepth(); };
  auto at = &ShoeScene::At;
  auto cloud_of = [&] { return scene.Cloud(); };
  const VoxelCloud all = cloud_of();
  const size_t shoe_voxels = ShoeScene::ShoeVoxels(all);
  ASSERT_GT(shoe_voxels, 50u);

  std::vector<KeyframeView> views(scene.views.begin(), scene.views.begin() + 3);
  MapCleaningOptions options;
  VoxelCloud two = cloud_of();
  EXPECT_EQ(CleanCloud(options, nullptr, {camera}, views, &two).seen_through_views, 0u);

  views.push_back(scene.views[3]);
  VoxelCloud three = cloud_of();
  const MapCleaningResult result = CleanCloud(options, nullptr, {camera}, views, &three);
  EXPECT_EQ(result.seen_through_views, shoe_voxels);
  size_t left = 0;
  three.ForEachPoint([&](const VoxelPoint& point) { left += point.position.z() < 2.8f; });
  EXPECT_EQ(left, 0u);
  EXPECT_EQ(three.OutputSize(), all.OutputSize() - shoe_voxels);

  // Views that cannot see the cloud change nothing, whether skipped as a whole (turned away,
  // 20 m aside) or judged voxel by voxel (a distorted camera turned away: only "behind" is
  // decided for the whole run): beside the two seeing through it, the shoe stays until a third.
  Eigen::Isometry3d away = at(0, 0, 0);
  away.linear() = Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitY()).toRotationMatrix();
  Camera distorted = camera;
  distorted.distortion[0] = 0.1;  // k1
  std::vector<KeyframeView> blind_views(views.begin(), views.begin() + 3);
  for (const Eigen::Isometry3d& pose : {away, at(20.0f, 0, 0)}) {
    blind_views.push_back(MakeKeyframeView(wall_depth(), cv::Mat(), pose));
    blind_views.push_back(MakeKeyframeView(wall_depth(), cv::Mat(), pose));
    blind_views.back().camera = 1;
  }
  VoxelCloud unseen = cloud_of();
  EXPECT_EQ(
      CleanCloud(options, nullptr, {camera, distorted}, blind_views, &unseen).seen_through_views,
      0u);
  blind_views.push_back(views[3]);
  VoxelCloud seen = cloud_of();
  EXPECT_EQ(
      CleanCloud(options, nullptr, {camera, distorted}, blind_views, &seen).seen_through_views,
      shoe_voxels);

  // A keyframe's masked pixels are no evidence: with the shoe's place masked in the three
  // others, nothing is dropped; and the check can be switched off.
  cv::Mat masked(camera.height, camera.width, CV_8UC1, cv::Scalar(0));
  masked(cv::Rect(40, 50, 80, 70)).setTo(255);
  for (size_t k = 1; k < views.size(); ++k) {
    views[k] = MakeKeyframeView(wall_depth(), masked,
                                k == 1   ? at(0.3f, 0, 0)
                                : k == 2 ? at(-0.3f, 0, 0)
                                         : at(0, 0.3f, 0));
  }
  VoxelCloud blind = cloud_of();
  EXPECT_EQ(CleanCloud(options, nullptr, {camera}, views, &blind).seen_through_views, 0u);
  options.clear_seen_through_views = false;
  VoxelCloud off = cloud_of();
  EXPECT_EQ(CleanCloud(options, nullptr, {camera}, views, &off).seen_through_views, 0u);
}

// Views whose every reading lies nearer than the shoe still saw it there when the readings fall
// within the margin (2 cm + 3 sigma, 5.4 cm at 2.7 m): two such views keep it beside the three
// seeing through it (3 is not more than twice 2). Readings 10 cm nearer are no evidence.
TEST(MapCleaningTest, ViewsWhoseFarthestReadingIsWithinTheMarginOfAVoxelStillJudgeIt) {
  const ShoeScene scene;
  const size_t shoe_voxels = ShoeScene::ShoeVoxels(scene.Cloud());
  ASSERT_GT(shoe_voxels, 50u);
  for (const float reading : {2.67f, 2.6f}) {
    std::vector<KeyframeView> views(scene.views.begin() + 1, scene.views.end());
    const cv::Mat near(scene.camera.height, scene.camera.width, CV_32FC1, cv::Scalar(reading));
    for (int k = 0; k < 2; ++k)
      views.push_back(MakeKeyframeView(near, cv::Mat(), scene.At(0, 0, 0)));
    VoxelCloud cloud = scene.Cloud();
    const MapCleaningResult result =
        CleanCloud(MapCleaningOptions(), nullptr, {scene.camera}, views, &cloud);
    EXPECT_EQ(result.seen_through_views, reading > 2.65f ? 0u : shoe_voxels) << reading << " m";
  }
}

// Views that saw a screen 1 m ahead everywhere but through a hole where the shoe is still saw
// it there: two of them keep it beside the three seeing through it. With the hole beside the
// shoe they are no evidence, and it goes.
TEST(MapCleaningTest, AViewSeeingAVoxelThroughAHoleInWhatHidesTheRestStillJudgesIt) {
  const ShoeScene scene;
  const size_t shoe_voxels = ShoeScene::ShoeVoxels(scene.Cloud());
  ASSERT_GT(shoe_voxels, 50u);
  for (const cv::Rect hole : {cv::Rect(70, 80, 12, 8), cv::Rect(90, 80, 12, 8)}) {
    cv::Mat screen(scene.camera.height, scene.camera.width, CV_32FC1, cv::Scalar(1.0f));
    screen(hole).setTo(2.7f);
    std::vector<KeyframeView> views(scene.views.begin() + 1, scene.views.end());
    for (int k = 0; k < 2; ++k) {
      views.push_back(MakeKeyframeView(screen, cv::Mat(), ShoeScene::At(0, 0, 0)));
    }
    VoxelCloud cloud = scene.Cloud();
    const MapCleaningResult result =
        CleanCloud(MapCleaningOptions(), nullptr, {scene.camera}, views, &cloud);
    EXPECT_EQ(result.seen_through_views, hole.x == 70 ? 0u : shoe_voxels) << hole;
  }
}

// Over a million voxels the views judge them a batch at a time: behind the cameras, 1.2 million
// voxels that come first in the cloud's order put the shoe in a later batch, and it goes as
// alone (the filler stays: no view sees it).
TEST(MapCleaningTest, VoxelsSeenThroughAreFoundInALaterBatch) {
  const ShoeScene scene;
  VoxelCloud cloud = scene.Cloud();
  std::vector<Eigen::Vector3f> filler;
  filler.reserve(size_t{1200} * 1000);
  for (int i = 0; i < 1200; ++i) {
    for (int j = 0; j < 1000; ++j) {
      filler.emplace_back(-20.0f + 0.01f * static_cast<float>(i) + 0.005f,
                          0.01f * static_cast<float>(j) + 0.005f, -5.0f);
    }
  }
  cloud.Insert(Colored(filler));
  const size_t before = cloud.OutputSize(), shoe_voxels = ShoeScene::ShoeVoxels(cloud);
  ASSERT_GT(before, size_t{1} << 20);
  ASSERT_GT(shoe_voxels, 50u);
  const MapCleaningResult result =
      CleanCloud(MapCleaningOptions(), nullptr, {scene.camera}, scene.views, &cloud);
  EXPECT_EQ(result.seen_through_views, shoe_voxels);
  EXPECT_EQ(ShoeScene::ShoeVoxels(cloud), 0u);
  EXPECT_EQ(cloud.OutputSize(), before - shoe_voxels);
}

// A camera whose projection throws points to +-1e30 pixels (the CLI refuses such a camera; the
// library must still not read outside the views): nothing is dropped, nothing read out of bounds.
TEST(MapCleaningTest, WildProjectionsStayInsideTheViews) {
  Camera camera = testing::SmallCamera(160, 120);
  camera.distortion = {1e10, -1e10, 0, 0, 1e10};
  std::vector<Eigen::Vector3f> points;
  for (int i = -20; i <= 20; ++i) {
    for (int j = -20; j <= 20; ++j) points.emplace_back(0.05f * i, 0.05f * j, 2.0f);
  }
  VoxelCloud cloud;
  cloud.Insert(Colored(points));
  const cv::Mat depth(camera.height, camera.width, CV_32FC1, cv::Scalar(3.0f));
  std::vector<KeyframeView> views;
  for (int k = 0; k < 3; ++k) {
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.translation().x() = 0.1 * k;
    views.push_back(MakeKeyframeView(depth, cv::Mat(), pose));
  }
  const size_t before = cloud.OutputSize();
  CleanCloud(MapCleaningOptions(), nullptr, {camera}, views, &cloud);
  EXPECT_LE(cloud.OutputSize(), before);
}
}  // namespace
}  // namespace stillmap
