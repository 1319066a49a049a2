// The synthetic generator against analytic truth.
#include "stillmap/synth/synthetic.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <sstream>

#include "stillmap/io/cloud_files.h"
#include "stillmap/io/error.h"
#include "stillmap/io/sequence.h"
#include "stillmap/io/trajectory.h"
#include "stillmap/synth/rasterizer.h"
#include "synthetic_scene.h"
#include "test_util.h"

namespace stillmap {
namespace {

namespace fs = std::filesystem;

TEST(RasterizerTest, DepthOfATiltedPlaneIsTheRayPlaneIntersection) {
  // The plane through (0, 0, 2) with normal tilted 30 degrees about x, seen head-on.
  const Camera camera = SynthCamera();
  const Eigen::Vector3f normal(0.0f, std::sin(0.5236f), -std::cos(0.5236f));
  const Eigen::Vector3f point(0.0f, 0.0f, 2.0f);
  const Eigen::Vector3f e1 = Eigen::Vector3f::UnitX();
  const Eigen::Vector3f e2 = normal.cross(e1).normalized();
  const TriangleMesh quad = MakeQuad(point - 10 * e1 - 10 * e2, 20 * e1, 20 * e2);
  Rasterizer raster(camera);
  raster.Draw(quad, Eigen::Isometry3f::Identity(), Eigen::Isometry3f::Identity(), 1, 0,
              Eigen::Vector3f::UnitZ());
  double worst = 0.0;
  int drawn = 0;
  for (int v = 0; v < camera.height; v += 7) {
    for (int u = 0; u < camera.width; u += 7) {
      const Eigen::Vector3d ray((u - camera.cx) / camera.fx, (v - camera.cy) / camera.fy, 1.0);
      const double z =
          normal.cast<double>().dot(point.cast<double>()) / normal.cast<double>().dot(ray);
      const float rendered = raster.buffers().depth.at<float>(v, u);
      if (z <= 0.0 || z > 50.0) continue;
      ASSERT_GT(rendered, 0.0f) << u << "," << v;
      worst = std::max(worst, std::abs(rendered - z) / z);
      ++drawn;
    }
  }
  EXPECT_GT(drawn, 5000);
  EXPECT_LT(worst, 1e-5);  // float precision, relative
}

TEST(RasterizerTest, ObjectPixelsAreExactlyThoseInsideItsProjectedTriangle) {
  const Camera camera = SynthCamera();
  Rasterizer raster(camera);
  // A static wall at 3 m and a moving triangle at about 1.5 m in front of it.
  raster.Draw(MakeQuad({-5, -5, 3}, {10, 0, 0}, {0, 10, 0}), Eigen::Isometry3f::Identity(),
              Eigen::Isometry3f::Identity(), 1, 0, Eigen::Vector3f::UnitZ());
  TriangleMesh triangle;
  triangle.vertices = {{-0.4f, -0.3f, 1.4f}, {0.5f, -0.1f, 1.6f}, {0.05f, 0.45f, 1.5f}};
  triangle.uvs = {{0, 0}, {1, 0}, {0, 1}};
  triangle.faces = {{0, 1, 2}};
  const std::uint16_t moving = synth::kFirstDynamicId;
  raster.Draw(triangle, Eigen::Isometry3f::Identity(), Eigen::Isometry3f::Identity(), moving, 0,
              Eigen::Vector3f::UnitZ());
  // Independently: project the corners and test each pixel centre in double precision.
  Eigen::Vector2d p[3];
  for (int k = 0; k < 3; ++k) {
    const Eigen::Vector3d q = triangle.vertices[k].cast<double>();
    p[k] = Eigen::Vector2d(camera.fx * q.x() / q.z() + camera.cx,
                           camera.fy * q.y() / q.z() + camera.cy);
  }
  auto edge = [](const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& c) {
    return (b.x() - a.x()) * (c.y() - a.y()) - (b.y() - a.y()) * (c.x() - a.x());
  };
  const double area = edge(p[0], p[1], p[2]);
  int inside = 0, mismatches = 0;
  for (int v = 0; v < camera.height; ++v) {
    for (int u = 0; u < camera.width; ++u) {
      const Eigen::Vector2d c(u, v);
      const double w[3] = {edge(p[1], p[2], c) / area, edge(p[2], p[0], c) / area,
                           edge(p[0], p[1], c) / area};
      const double margin = std::min({w[0], w[1], w[2]});
      if (std::abs(margin) < 1e-4) continue;  // on an edge: either answer is right
      const bool expected = margin > 0.0;
      inside += expected;
      mismatches += expected != (raster.buffers().object_id.at<std::uint16_t>(v, u) == moving);
    }
  }
  EXPECT_GT(inside, 20000);
  EXPECT_EQ(mismatches, 0);
}

TEST(MeshTest, ObjRoundTripsThroughAssimp) {
  testing::TempDir dir;
  const TriangleMesh box = MakeBox({1, 2, 3}, {0.5f, 0.4f, 0.3f}, 0.25f);
  WriteObj(dir / "box.obj", box);
  const TriangleMesh loaded = LoadMesh(dir / "box.obj");
  ASSERT_EQ(loaded.faces.size(), 12u);
  EXPECT_NEAR(loaded.Area(), box.Area(), 1e-5);
  EXPECT_NEAR(box.Area(), 2 * (0.5 * 0.4 + 0.5 * 0.3 + 0.4 * 0.3), 1e-6);
  testing::WriteText(dir / "broken.obj", "this is not a mesh\n");
  EXPECT_THROW(LoadMesh(dir / "broken.obj"), InputError);
}

// A short walking sequence, generated once for the tests below.
class SyntheticSequenceTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new testing::TempDir;
    SynthOptions options;
    options.scenario = "walking_xyz";
    options.frames = 8;
    summary_ = WriteSyntheticSequence(*dir_ / "seq", options);
  }
  static void TearDownTestSuite() { delete dir_; }
  static std::string Dir() { return *dir_ / "seq"; }

  static testing::TempDir* dir_;
  static SynthSummary summary_;
};
testing::TempDir* SyntheticSequenceTest::dir_ = nullptr;
SynthSummary SyntheticSequenceTest::summary_;

TEST_F(SyntheticSequenceTest, WritesTheTumLayoutAndItsGroundTruth) {
  for (const char* name : {"rgb.txt", "depth.txt", "masks.txt", "groundtruth.txt", "camera.yaml",
                           "static_gt.ply", "objects.txt", "synth.json"}) {
    EXPECT_TRUE(fs::exists(Dir() + "/" + name)) << name;
  }
  const Sequence sequence = Sequence::Open(Dir(), ResolveCamera(Dir(), {}));
  EXPECT_EQ(sequence.frames().size(), 8u);
  EXPECT_GT(summary_.static_gt_points, 100000u);
  EXPECT_GT(summary_.dynamic_pixel_share, 0.01);
  // Two people, one line per frame each.
  std::ifstream objects(Dir() + "/objects.txt");
  std::string line;
  int lines = 0;
  while (std::getline(objects, line)) lines += !line.empty() && line[0] != '#';
  EXPECT_EQ(lines, 16);
}

TEST_F(SyntheticSequenceTest, GroundTruthTrajectoryIsTheRenderingTrajectory) {
  const Trajectory trajectory = Trajectory::ReadTum(Dir() + "/groundtruth.txt");
  ASSERT_EQ(trajectory.size(), 8u);
  for (size_t i = 0; i < trajectory.size(); ++i) {
    const Eigen::Isometry3d rendered = synth::CameraPose("walking_xyz", i / 30.0).cast<double>();
    EXPECT_NEAR(trajectory.poses()[i].time, 1000.0 + i / 30.0, 1e-6);
    EXPECT_LT((trajectory.poses()[i].world_from_camera.matrix() - rendered.matrix()).norm(), 1e-6);
  }
}

TEST_F(SyntheticSequenceTest, StaticGroundTruthProjectsOntoTheRenderedDepth) {
  const Camera camera = ResolveCamera(Dir(), {});
  const Sequence sequence = Sequence::Open(Dir(), camera);
  const Frame frame = sequence.LoadFrame(3);
  const cv::Mat mask =
      cv::imread(Dir() + "/masks/" + fs::path(sequence.frames()[3].color_path).filename().string(),
                 cv::IMREAD_UNCHANGED);
  const Eigen::Isometry3f camera_from_world =
      sequence.groundtruth()->poses()[3].world_from_camera.inverse().cast<float>();
  std::vector<double> normalized;  // |dz| / sigma(z)
  for (const VoxelPoint& p : ReadCloud(Dir() + "/static_gt.ply")) {
    const Eigen::Vector3f q = camera_from_world * p.position;
    if (q.z() < 0.5f) continue;
    const int u = static_cast<int>(std::lround(camera.fx * q.x() / q.z() + camera.cx));
    const int v = static_cast<int>(std::lround(camera.fy * q.y() / q.z() + camera.cy));
    if (u < 1 || v < 1 || u >= camera.width - 1 || v >= camera.height - 1) continue;
    const float measured = frame.depth_m.at<float>(v, u);
    if (measured == 0.0f || mask.at<std::uint8_t>(v, u) != 0) continue;
    if (std::abs(measured - q.z()) > 0.3f) continue;  // a nearer static surface hides the point
    const double sigma = 0.0012 + 0.0019 * (q.z() - 0.4) * (q.z() - 0.4);
    // Rounding to the pixel centre moves the lookup by up to half a pixel: on a surface slanted
    // by up to 70 degrees that changes depth by 0.5 z tan(70 deg) / fx.
    const double rounding = 0.5 * q.z() * std::tan(70.0 * M_PI / 180.0) / camera.fx;
    normalized.push_back(std::abs(measured - q.z()) / (sigma + rounding));
  }
  ASSERT_GT(normalized.size(), 10000u);
  std::sort(normalized.begin(), normalized.end());
  EXPECT_LT(normalized[normalized.size() / 2], 1.0);
  EXPECT_LT(normalized[normalized.size() * 95 / 100], 3.0);
}

TEST_F(SyntheticSequenceTest, SameSeedSameBytesWhateverTheThreads) {
  testing::TempDir dir;
  SynthOptions options;
  options.scenario = "walking_xyz";
  options.frames = 8;
  options.threads = 1;
  WriteSyntheticSequence(dir / "again", options);
  for (const char* folder : {"rgb", "depth", "masks"}) {
    for (const auto& entry : fs::directory_iterator(Dir() + "/" + folder)) {
      const std::string other =
          dir / ("again/" + std::string(folder) + "/" + entry.path().filename().string());
      ASSERT_TRUE(fs::exists(other)) << other;
      EXPECT_TRUE(testing::ReadText(entry.path().string()) == testing::ReadText(other)) << other;
    }
  }
  EXPECT_TRUE(testing::ReadText(Dir() + "/static_gt.ply") ==
              testing::ReadText(dir / "again/static_gt.ply"));
}

TEST_F(SyntheticSequenceTest, SceneMeshesLoadThroughAssimp) {
  size_t meshes = 0;
  for (const auto& entry : fs::directory_iterator(Dir() + "/scene")) {
    EXPECT_FALSE(LoadMesh(entry.path().string()).faces.empty()) << entry.path();
    ++meshes;
  }
  EXPECT_GT(meshes, 20u);
}

TEST(SynthOptionsTest, BadOptionsAndFoldersAreRefused) {
  testing::TempDir dir;
  SynthOptions options;
  options.scenario = "dancing";
  EXPECT_THROW(WriteSyntheticSequence(dir / "a", options), InputError);
  options.scenario = "static";
  options.frames = 1;
  EXPECT_THROW(WriteSyntheticSequence(dir / "a", options), InputError);
  testing::WriteText(dir / "notes.txt", "my files");
  options.frames = 4;
  EXPECT_THROW(WriteSyntheticSequence(dir.path(), options), InputError);  // not a synth folder
  EXPECT_TRUE(fs::exists(dir / "notes.txt"));
}

}  // namespace
}  // namespace stillmap
