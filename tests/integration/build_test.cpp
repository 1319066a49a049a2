// The build pipeline end to end on synthetic sequences with exact truth (planes, rooms, walking
// people): every output, ghosts, masks and the grid. Tracking's own outputs are checked in
// tracked_build_test.cpp, the real sequences in real_data_test.cpp.
#include <gtest/gtest.h>
#include <octomap/OcTree.h>

#include <filesystem>
#include <iostream>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <vector>

#include "build_helpers.h"
#include "scenario.h"
#include "stillmap/io/camera.h"
#include "stillmap/io/cloud_files.h"
#include "stillmap/io/trajectory.h"
#include "stillmap/mapping/map_quality.h"
#include "stillmap/pipeline/build_pipeline.h"
#include "stillmap/synth/mesh.h"
#include "test_util.h"

namespace stillmap {
namespace {

namespace fs = std::filesystem;
using testing::kOutputs;
using testing::TrackRepeatably;
using testing::WriteScenario;

TEST(BuildTest, PlaneSequenceFromGroundTruthWritesEveryOutput) {
  testing::TempDir dir;
  const Camera camera = testing::SmallCamera(96, 72);
  std::vector<Eigen::Isometry3d> poses;
  for (int i = 0; i < 6; ++i) {
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.translation() = Eigen::Vector3d(0.05 * i, 0.0, 0.0);
    poses.push_back(pose);
  }
  const Trajectory truth = testing::WritePlaneSequence(dir / "seq", camera, {}, poses);

  BuildRequest request;
  request.sequence_dir = dir / "seq";
  request.output_dir = dir / "out";
  request.config.run.poses = "groundtruth";
  ApplySetArgument(&request.config, "mapping.voxel_leaf_size=0.02");
  ApplySetArgument(&request.config, "map.frame=groundtruth");  // the truth's frame, exactly
  const BuildResult summary = RunBuild(request);
  EXPECT_EQ(summary.frames.fused, 6u);
  EXPECT_EQ(summary.frames.without_pose, 0u);

  for (const char* name : kOutputs) EXPECT_TRUE(fs::exists(dir / "out/" + name)) << name;
  for (const auto& entry : fs::recursive_directory_iterator(dir / "out")) {
    EXPECT_NE(entry.path().extension(), ".tmp") << "temporary file left: " << entry.path();
  }

  // The cloud is the plane z = 2 m, seen over x in [-0.6, 0.85] m.
  const std::vector<VoxelPoint> cloud = ReadCloud(dir / "out/map.ply");
  ASSERT_EQ(cloud.size(), summary.map.voxels_written);
  for (const VoxelPoint& p : cloud) EXPECT_NEAR(p.position.z(), 2.0, 1e-3);

  // The trajectory written is the one rendered.
  const Trajectory written = Trajectory::ReadTum(dir / "out/trajectory.txt");
  ASSERT_EQ(written.size(), truth.size());
  for (size_t i = 0; i < truth.size(); ++i) {
    EXPECT_TRUE(
        written.poses()[i].world_from_camera.isApprox(truth.poses()[i].world_from_camera, 1e-8));
  }

  // The OctoMap opens in OctoMap and has the wall occupied, the space before it free.
  octomap::OcTree tree(0.1);
  ASSERT_TRUE(tree.readBinary(dir / "out/map.bt"));
  const octomap::OcTreeNode* wall = tree.search(0.1, 0.0, 2.0);
  ASSERT_NE(wall, nullptr);
  EXPECT_TRUE(tree.isNodeOccupied(wall));
  const octomap::OcTreeNode* before = tree.search(0.1, 0.0, 1.0);
  ASSERT_NE(before, nullptr);
  EXPECT_FALSE(tree.isNodeOccupied(before));

  // The mesh reads back through assimp and lies on the plane (voxels of 3 cm straddle it).
  const TriangleMesh mesh = LoadMesh(dir / "out/mesh.glb");
  ASSERT_GT(mesh.faces.size(), 100u);
  for (const Eigen::Vector3f& v : mesh.vertices) EXPECT_NEAR(v.z(), 2.0, 0.031);

  // `stillmap view OUT --png` draws the same renders again from the files (poses and the grid
  // frame come back rounded to the files' precision: nearly the same pixels).
  std::vector<cv::Mat> rendered;
  for (const char* name : {"grid_top.png", "cloud_view_1.png", "cloud_view_2.png"}) {
    rendered.push_back(cv::imread(dir / "out/renders/" + name));
  }
  std::string output;
  ASSERT_EQ(testing::RunStillmap("view " + (dir / "out") + " --png", &output), 0) << output;
  int k = 0;
  for (const char* name : {"grid_top.png", "cloud_view_1.png", "cloud_view_2.png"}) {
    const cv::Mat again = cv::imread(dir / "out/renders/" + name);
    ASSERT_EQ(again.size(), rendered[static_cast<size_t>(k)].size()) << name;
    cv::Mat difference;
    cv::absdiff(again, rendered[static_cast<size_t>(k++)], difference);
    EXPECT_LT(cv::mean(difference)[0], 2.0) << name;
  }
  // The window under a virtual display (xvfb, installed by scripts/setup.sh): it opens, renders,
  // and its screenshot shows the cloud (not one flat color).
  if (std::system("command -v xvfb-run > /dev/null 2>&1") != 0) {
    std::cout << "SKIPPED part: xvfb-run not found (apt-get install xvfb); window not tested\n";
  } else {
    ASSERT_EQ(testing::RunStillmap("view " + (dir / "out") + " --screenshot " + (dir / "shot.png"),
                                   &output, "xvfb-run -a -s '-screen 0 1280x1024x24'"),
              0)
        << output;
    const cv::Mat shot = cv::imread(dir / "shot.png");
    ASSERT_FALSE(shot.empty());
    cv::Scalar mean, deviation;
    cv::meanStdDev(shot, mean, deviation);
    EXPECT_GT(deviation[0] + deviation[1] + deviation[2], 10.0);
  }

  const nlohmann::json report = nlohmann::json::parse(testing::ReadText(dir / "out/report.json"));
  EXPECT_EQ(report["mesh"]["triangles"], mesh.faces.size());
  // A wall facing the camera has no floor: the grid says how it placed the floor instead.
  EXPECT_NE(report["grid"]["floor"]["source"].get<std::string>().find("no horizontal plane"),
            std::string::npos);
  EXPECT_EQ(report["frames"]["fused"], 6);
  EXPECT_EQ(report["map"]["voxels_written"], cloud.size());
  EXPECT_GT(report["timing"]["frames_per_second"].get<double>(), 0.0);
  EXPECT_GT(report["timing"]["peak_memory_mib"].get<double>(), 0.0);
  // The memory breakdown: the voxel table as the map section counts it, and the highest reading
  // within the process's peak.
  const nlohmann::json& memory = report["timing"]["memory"];
  EXPECT_GT(memory["samples"].get<int>(), 2);
  EXPECT_NEAR(memory["owners_largest_mib"]["voxel_cloud"].get<double>(),
              report["map"]["voxel_table_mib"].get<double>(), 1e-9);
  EXPECT_LE(memory["highest_mib"].get<double>(),
            report["timing"]["peak_memory_mib"].get<double>() + 1.0);
  EXPECT_GE(memory["highest_mib"].get<double>(), memory["highest_sample_mib"].get<double>());
  // The program's code and libraries: some, never more than the sample's resident memory.
  const double code_mib = memory["owners_at_highest_sample_mib"]["code_and_libraries"];
  EXPECT_GT(code_mib, 1.0);
  EXPECT_LT(code_mib, memory["highest_sample_mib"].get<double>());
  EXPECT_FALSE(memory["highest_phase"].get<std::string>().empty());
  EXPECT_NE(testing::ReadText(dir / "out/config.yaml").find("voxel_leaf_size: 0.02"),
            std::string::npos);
}

TEST(BuildTest, FramesOutsideTheGroundTruthAreLeftOutNotInvented) {
  testing::TempDir dir;
  std::vector<Eigen::Isometry3d> poses(5, Eigen::Isometry3d::Identity());
  testing::WritePlaneSequence(dir / "seq", testing::SmallCamera(), {}, poses);
  // Keep ground truth for the middle three frames only.
  const Trajectory truth = Trajectory::ReadTum(dir / "seq/groundtruth.txt");
  Trajectory(std::vector<StampedPose>(truth.poses().begin() + 1, truth.poses().end() - 1))
      .WriteTum(dir / "seq/groundtruth.txt");
  BuildRequest request;
  request.sequence_dir = dir / "seq";
  request.output_dir = dir / "out";
  request.config.run.poses = "groundtruth";
  request.config.run.threads = 1;
  const BuildResult summary = RunBuild(request);
  EXPECT_EQ(summary.frames.fused, 3u);
  EXPECT_EQ(summary.frames.without_pose, 2u);
  EXPECT_EQ(Trajectory::ReadTum(dir / "out/trajectory.txt").size(), 3u);
}

// Synthetic sequences with exact ground truth (issue 3): a static room mapped from its true poses
// lies on the true surface; with people walking and no masking, their ghosts show.
MapQuality BuildSynthetic(const std::string& scenario, const std::string& dir,
                          const std::vector<std::string>& settings = {}) {
  WriteScenario(dir + "/seq", scenario, 60);
  BuildRequest request;
  request.sequence_dir = dir + "/seq";
  request.output_dir = dir + "/out";
  request.config.run.poses = "groundtruth";
  request.config.masking_enabled = false;
  for (const std::string& setting : settings) ApplySetArgument(&request.config, setting);
  const BuildResult summary = RunBuild(request);
  EXPECT_TRUE(summary.evaluation.map_quality.has_value());
  const nlohmann::json report = nlohmann::json::parse(testing::ReadText(dir + "/out/report.json"));
  EXPECT_TRUE(report.contains("map_quality"));
  std::cout << scenario << " (60 frames, ground-truth poses, no masking): accuracy median "
            << summary.evaluation.map_quality->accuracy_median * 1e3 << " mm, completeness "
            << 100.0 * summary.evaluation.map_quality->completeness << " %, ghost share "
            << 100.0 * summary.evaluation.map_quality->ghost_share << " %\n";
  return *summary.evaluation.map_quality;
}

TEST(BuildTest, SyntheticStaticRoomFromGroundTruthLiesOnTheTrueSurface) {
  testing::TempDir dir;
  const MapQuality quality = BuildSynthetic("static", dir.path());
  EXPECT_LT(quality.accuracy_median, 0.01);
  EXPECT_GT(quality.completeness, 0.9);
  EXPECT_LT(quality.ghost_share, 0.01);
}

TEST(BuildTest, SyntheticWalkingPeopleLeaveGhostsWithoutMasking) {
  testing::TempDir dir;
  // The problem the dynamic rejection solves, with the map cleaning off too.
  const MapQuality raw = BuildSynthetic(
      "walking_xyz", dir.path(),
      {"mapping.clear_seen_through=false", "mapping.clear_seen_through_views=false"});
  EXPECT_GT(raw.ghost_share, 0.05);
  EXPECT_GT(raw.completeness, 0.9);
  // The cleaning alone (the OctoMap's and the keyframes' see-through checks) removes most of the
  // people without any mask (measured: ghosts 39.9 -> 3.4 %), though far from the 0.1 % of the
  // masked maps.
  testing::TempDir cleaned_dir;
  const MapQuality cleaned = BuildSynthetic("walking_xyz", cleaned_dir.path());
  EXPECT_LT(cleaned.ghost_share, 0.2 * raw.ghost_share);
  EXPECT_GT(cleaned.ghost_share, 0.01);
  EXPECT_GT(cleaned.completeness, 0.9);
}

// Builds DIR/seq into DIR/OUT through the binary with --quiet and `extra`; returns its report.
nlohmann::json BuildWithBinary(const testing::TempDir& dir, const std::string& out,
                               const std::string& extra) {
  std::string output;
  EXPECT_EQ(testing::RunStillmap(
                "build " + (dir / "seq") + " -o " + (dir / out) + " --quiet" + extra, &output),
            0)
      << output;
  return nlohmann::json::parse(testing::ReadText(dir / out + "/report.json"));
}

// The 2-D grid of a tracked walking sequence against the occupancy of the static scene over the
// same band (static_gt.ply), with and without dynamic rejection. Measured (150 frames): agreement
// 0.968 on 3409 observed cells, 1 cell occupied with no static structure within a cell (a remnant
// of a person; issue 6 asks for none), against 0.945 and 45 without rejection.
TEST(BuildTest, GridOfAWalkingSequenceAgreesWithTheStaticScene) {
  testing::TempDir dir;
  WriteScenario(dir / "seq", "walking_xyz", 150);
  const nlohmann::json masked = BuildWithBinary(dir, "masked", "");
  const nlohmann::json unmasked = BuildWithBinary(dir, "unmasked", " --set masking.enabled=false");
  const nlohmann::json& quality = masked.at("grid_quality");
  const nlohmann::json& without = unmasked.at("grid_quality");
  std::cout << "walking_xyz grid: agreement " << quality.at("agreement") << " on "
            << quality.at("observed_cells") << " cells, occupied without static truth "
            << quality.at("occupied_without_static_truth") << " (without rejection "
            << without.at("agreement") << ", " << without.at("occupied_without_static_truth")
            << ")\n";
  EXPECT_EQ(masked.at("grid").at("floor").at("source"), "fitted");
  // The KLT window and corners the masks used: 15 px and 300 with a detector (models found),
  // 21 px and 400 without.
  const bool semantics = masked.at("masking").at("semantics").get<bool>();
  EXPECT_EQ(masked.at("masking").at("flow_klt_window_px").get<int>(), semantics ? 15 : 21);
  EXPECT_EQ(masked.at("masking").at("flow_points").get<int>(), semantics ? 300 : 400);
  // Unclaimed moving regions are outlined with a detector only (20000 px), where they are the
  // people it missed; without one they are every person.
  EXPECT_EQ(masked.at("masking").at("unclaimed_outline_min_px").get<int>(), semantics ? 20000 : 0);
  EXPECT_LT(masked.at("grid").at("floor").at("tilt_to_cameras_up_deg").get<double>(), 15.0);
  EXPECT_GE(quality.at("agreement").get<double>(), 0.95);
  EXPECT_GT(quality.at("observed_cells").get<size_t>(), 2000u);
  EXPECT_LT(2 * quality.at("occupied_without_static_truth").get<size_t>(),
            without.at("occupied_without_static_truth").get<size_t>());
  EXPECT_LE(quality.at("free_where_truth_occupied").get<size_t>(), 5u);
  // Issue 6: no cell occupied only because a person stood there (measured 0 of 47 such cells
  // without rejection; the one cell left above lies 1.7 m from both paths, 12 cm from the
  // nearest static truth).
  EXPECT_EQ(quality.at("of_those_on_moving_objects_paths").get<size_t>(), 0u);
  EXPECT_GT(without.at("of_those_on_moving_objects_paths").get<size_t>(), 10u);
  // With the OctoMap on, cloud voxels its rays later saw through are dropped (issue 5's 0.5 %
  // ghost target; measured 0.08 %).
  std::cout << "walking_xyz map: ghosts "
            << 100.0 * masked.at("map_quality").at("ghost_share").get<double>() << " %, "
            << masked.at("map").at("voxels_removed_seen_through") << " voxels seen through\n";
  EXPECT_GT(masked.at("map").at("voxels_removed_seen_through").get<size_t>(), 0u);
  EXPECT_LE(masked.at("map_quality").at("ghost_share").get<double>(), 0.005);
  EXPECT_GT(masked.at("map_quality").at("completeness").get<double>(), 0.9);
  // The map_server pair: the YAML names the image, which has the grid's size.
  const std::string yaml = testing::ReadText(dir / "masked/grid.yaml");
  EXPECT_NE(yaml.find("image: grid.pgm"), std::string::npos);
  const cv::Mat image = cv::imread(dir / "masked/grid.pgm", cv::IMREAD_UNCHANGED);
  EXPECT_EQ(image.cols, masked.at("grid").at("width").get<int>());
  EXPECT_EQ(image.rows, masked.at("grid").at("height").get<int>());
}

// Dynamic rejection (issue 5) through the binary, tracked, geometry only (no detector): the masks
// are scored against the rendered ones, the map against the static scene, and both against the
// same run without rejection.
TEST(BuildTest, DynamicRejectionMasksWalkingPeopleAndKeepsTheirGhostsOut) {
  testing::TempDir dir;
  WriteScenario(dir / "seq", "walking_xyz", 120);
  const std::string no_octomap = " --set octomap.enabled=false";
  const nlohmann::json masked = BuildWithBinary(dir, "masked", no_octomap);
  const nlohmann::json unmasked =
      BuildWithBinary(dir, "unmasked", no_octomap + " --set masking.enabled=false");
  const nlohmann::json& score = masked.at("mask_quality");
  std::cout << "walking_xyz, 120 frames, geometry only: mask precision " << score.at("precision")
            << ", recall " << score.at("recall") << "; ghosts "
            << 100.0 * masked.at("map_quality").at("ghost_share").get<double>() << " % (without "
            << 100.0 * unmasked.at("map_quality").at("ghost_share").get<double>()
            << " %), completeness "
            << 100.0 * masked.at("map_quality").at("completeness").get<double>() << " %; ATE "
            << masked.at("trajectory_error").at("ate_m").at("rmse").get<double>() * 1e3
            << " mm (without "
            << unmasked.at("trajectory_error").at("ate_m").at("rmse").get<double>() * 1e3
            << " mm)\n";
  // Measured: precision 0.93, recall 0.94 (the first frames have no reference yet).
  EXPECT_GT(score.at("precision").get<double>(), 0.85);
  EXPECT_GT(score.at("recall").get<double>(), 0.8);
  EXPECT_FALSE(unmasked.contains("mask_quality"));
  EXPECT_LT(masked.at("map_quality").at("ghost_share").get<double>(),
            0.25 * unmasked.at("map_quality").at("ghost_share").get<double>());
  EXPECT_LT(masked.at("map_quality").at("ghost_share").get<double>(), 0.02);
  EXPECT_GT(masked.at("map_quality").at("completeness").get<double>(), 0.85);
  EXPECT_LT(masked.at("trajectory_error").at("ate_m").at("rmse").get<double>(),
            unmasked.at("trajectory_error").at("ate_m").at("rmse").get<double>());
  // Keyframe selection: every tracking keyframe is culled by the tracker (the keyframes kept
  // before it saw its view), or fused, invalid or redundant, and keyframes.txt lists the fused
  // ones. The camera sways over one place: some are culled or redundant.
  const nlohmann::json& keyframes = masked.at("keyframes");
  const size_t fused = keyframes.at("fused"), invalid = keyframes.at("rejected_invalid"),
               redundant = keyframes.at("rejected_redundant"), culled = keyframes.at("culled");
  EXPECT_EQ(fused + invalid + redundant + culled,
            masked.at("tracking").at("keyframes").get<size_t>());
  EXPECT_GT(redundant + culled, 0U);
  EXPECT_EQ(Trajectory::ReadTum(dir / "masked/keyframes.txt").size(), fused);
  EXPECT_EQ(unmasked.at("masking").at("enabled"), false);
  EXPECT_GT(
      masked.at("timing").at("stages_ms").at("masking_ms").at("mask").at("median").get<double>(),
      0.0);
}

}  // namespace
}  // namespace stillmap
