// The build pipeline end to end on synthetic sequences with exact truth (planes, rooms, walking
// people). The real sequences are in real_data_test.cpp.
#include <gtest/gtest.h>
#include <octomap/OcTree.h>
#include <pcl/kdtree/kdtree_flann.h>
#include <pcl/point_types.h>

#include <filesystem>
#include <iostream>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <vector>

#include "build_helpers.h"
#include "stillmap/io/camera.h"
#include "stillmap/io/cloud_files.h"
#include "stillmap/io/evaluation.h"
#include "stillmap/io/sequence.h"
#include "stillmap/io/trajectory.h"
#include "stillmap/mapping/back_projection.h"
#include "stillmap/mapping/map_quality.h"
#include "stillmap/mapping/occupancy_grid.h"
#include "stillmap/pipeline/build_pipeline.h"
#include "stillmap/synth/mesh.h"
#include "stillmap/synth/synthetic.h"
#include "stillmap/tracking/depth_correction.h"
#include "test_util.h"

namespace stillmap {
namespace {

namespace fs = std::filesystem;
using testing::kOutputs;
using testing::TrackRepeatably;

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
  request.poses = PoseSource::kGroundTruth;
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
  request.poses = PoseSource::kGroundTruth;
  request.threads = 1;
  const BuildResult summary = RunBuild(request);
  EXPECT_EQ(summary.frames.fused, 3u);
  EXPECT_EQ(summary.frames.without_pose, 2u);
  EXPECT_EQ(Trajectory::ReadTum(dir / "out/trajectory.txt").size(), 3u);
}

// Real data: TUM fr3/teddy from its motion-capture poses. A sharp map agrees with frames it was
// not built from: frames 46, 50 and 55, back-projected with their ground-truth poses, lie close
// to the map of frames 5-44 (nearest map point). For scale: a 1 cm voxel grid alone leaves up to
// 8.7 mm to the nearest voxel centroid (about 3-4 mm typical on a surface), and depth noise of
// the Kinect at 1-2 m is a few mm.
// Writes a synthetic sequence of `scenario`, `frames` frames long, to `sequence_dir`.
void WriteScenario(const std::string& sequence_dir, const std::string& scenario, size_t frames) {
  SynthOptions options;
  options.scenario = scenario;
  options.frames = frames;
  WriteSyntheticSequence(sequence_dir, options);
}

// Synthetic sequences with exact ground truth (issue 3): a static room mapped from its true poses
// lies on the true surface; with people walking and no masking, their ghosts show.
MapQuality BuildSynthetic(const std::string& scenario, const std::string& dir,
                          const std::vector<std::string>& settings = {}) {
  WriteScenario(dir + "/seq", scenario, 60);
  BuildRequest request;
  request.sequence_dir = dir + "/seq";
  request.output_dir = dir + "/out";
  request.poses = PoseSource::kGroundTruth;
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

// Tracking (issue 4), the default of `stillmap build`, through the binary: a synthetic static room
// with exact ground truth. Every frame is tracked, every output is written, keyframes are the
// fused frames, and report.json holds ATE/RPE against the rendering poses.
TEST(BuildTest, TrackingASyntheticRoomWritesTrajectoryKeyframesAndErrors) {
  testing::TempDir dir;
  WriteScenario(dir / "seq", "static", 90);
  std::string output;
  ASSERT_EQ(testing::RunStillmap("build " + dir / "seq" + " -o " + dir / "out" +
                                     " --detector none --quiet --set octomap.resolution=0.1",
                                 &output),
            0)
      << output;
  for (const char* name : kOutputs) EXPECT_TRUE(fs::exists(dir / "out/" + name)) << name;
  const Trajectory trajectory = Trajectory::ReadTum(dir / "out/trajectory.txt");
  const Trajectory keyframes = Trajectory::ReadTum(dir / "out/keyframes.txt");
  EXPECT_EQ(trajectory.size(), 90u);
  ASSERT_GE(keyframes.size(), 3u);
  EXPECT_LT(keyframes.size(), trajectory.size());
  // The map frame stands under the first camera, x along its view: no sideways offset.
  EXPECT_LT(trajectory.poses()[0].world_from_camera.translation().head<2>().norm(), 1e-6);

  const nlohmann::json report = nlohmann::json::parse(testing::ReadText(dir / "out/report.json"));
  EXPECT_EQ(report["poses"], "tracking");
  EXPECT_EQ(report["tracking"]["tracked"], 90);
  EXPECT_EQ(report["tracking"]["lost"], 0);
  EXPECT_EQ(report["tracking"]["keyframes"], keyframes.size());
  EXPECT_EQ(report["frames"]["fused"], keyframes.size());
  for (const char* stage : {"extract", "match", "pose", "local_bundle_adjustment"}) {
    EXPECT_TRUE(report["timing"]["stages_ms"]["tracking_ms"].contains(stage)) << stage;
  }
  // The allocator the binary was linked with is the one that ran (CMakeLists.txt).
  EXPECT_EQ(report["timing"]["cpu"]["allocator"].get<std::string>(), STILLMAP_ALLOCATOR);
  // The report's ATE agrees with one recomputed here from the written trajectory.
  const Trajectory truth = Trajectory::ReadTum(dir / "seq/groundtruth.txt");
  const AteResult ate = ComputeAte(truth, trajectory);
  const double reported = report["trajectory_error"]["ate_m"]["rmse"];
  EXPECT_NEAR(reported, ate.translation.rmse, 1e-9);
  std::cout << "synthetic static room, 90 frames tracked: ATE RMSE " << ate.translation.rmse * 1e3
            << " mm, " << keyframes.size() << " keyframes\n";
  EXPECT_LT(ate.translation.rmse, 0.005);
  EXPECT_EQ(report["trajectory_error"]["rpe_translation_m"]["count"].get<size_t>() > 0, true);
  // The tracked map, anchored at the first frame's ground-truth pose, lies near the true surface
  // (measured 4.1 mm median, 99 % complete; 4.8 mm from ground-truth poses, over 60 frames).
  ASSERT_TRUE(report["map_quality"].is_object()) << report.dump(2);
  EXPECT_EQ(report["map_quality"]["aligned_by"],
            "the ground-truth pose of the first tracked frame that has one");
  const double accuracy_median = report["map_quality"]["accuracy_median_m"];
  const double completeness = report["map_quality"]["completeness"];
  std::cout << "tracked map vs static_gt.ply: accuracy median " << accuracy_median * 1e3
            << " mm, completeness " << 100.0 * completeness << " %\n";
  EXPECT_LT(accuracy_median, 0.015);
  EXPECT_GT(completeness, 0.9);
}

// Every 3-D output in one z-up frame on the floor (map.frame=floor, the default), in both pose
// modes, against the synthetic room's truth (its world is z up with the floor at z = 0): the
// cloud's floor (fitted here by least squares) within 2 degrees of +z and 2 cm of z = 0; the
// cameras' heights and up axes in trajectory.txt and keyframes.txt those of the ground truth; the
// OctoMap's and the mesh's floor at z = 0; the grid's frame the map frame itself.
TEST(BuildTest, EveryOutputStandsOnTheFloorInBothPoseModes) {
  testing::TempDir dir;
  WriteScenario(dir / "seq", "static", 60);
  const Trajectory truth = Trajectory::ReadTum(dir / "seq/groundtruth.txt");
  for (const std::string poses : {"tracking", "groundtruth"}) {
    const std::string out = dir / ("out_" + poses);
    std::string command = "build " + dir / "seq" + " -o " + out;
    command += " --poses " + poses + " --detector none --quiet";
    std::string output;
    ASSERT_EQ(testing::RunStillmap(command, &output), 0) << output;
    const testing::FloorCheck floor = testing::CheckFloor(ReadCloud(out + "/map.ply"));
    std::cout << poses << ": floor tilt " << floor.tilt_deg << " deg, height at the origin "
              << floor.height_at_origin * 1e3 << " mm, " << 100 * floor.share_near
              << " % of the points on it, " << 100 * floor.share_below << " % below\n";
    EXPECT_LT(floor.tilt_deg, 2.0) << poses;
    EXPECT_LT(std::abs(floor.height_at_origin), 0.02) << poses;
    EXPECT_GT(floor.share_near, 0.1) << poses;
    EXPECT_LT(floor.share_below, 0.005) << poses;
    for (const char* file : {"trajectory.txt", "keyframes.txt"}) {
      const Trajectory written = Trajectory::ReadTum(out + "/" + file);
      ASSERT_GT(written.size(), 2u) << file;
      for (const StampedPose& pose : written.poses()) {
        const std::optional<Eigen::Isometry3d> true_pose = truth.Interpolate(pose.time, 0.1);
        ASSERT_TRUE(true_pose.has_value());
        EXPECT_NEAR(pose.world_from_camera.translation().z(), true_pose->translation().z(), 0.02)
            << poses << " " << file << " " << pose.time;
        // The world's up seen from the camera: the same direction in both.
        const Eigen::Vector3d up = pose.world_from_camera.linear().row(2).transpose();
        const Eigen::Vector3d true_up = true_pose->linear().row(2).transpose();
        EXPECT_LT(std::acos(std::min(1.0, up.dot(true_up))) * 180.0 / M_PI, 2.0) << poses << file;
      }
    }
    // The OctoMap as OctoMap reads it: its occupied voxels rest on z = 0.
    octomap::OcTree tree(0.1);
    ASSERT_TRUE(tree.readBinary(out + "/map.bt"));
    size_t occupied = 0, on_floor = 0, under = 0;
    for (auto it = tree.begin_leafs(); it != tree.end_leafs(); ++it) {
      if (!tree.isNodeOccupied(*it)) continue;
      ++occupied;
      on_floor += std::abs(it.getZ()) < 0.08 ? 1 : 0;
      under += it.getZ() < -0.1 ? 1 : 0;
    }
    EXPECT_GT(on_floor, occupied / 5) << poses;
    EXPECT_LT(under, occupied / 100 + 1) << poses;
    const TriangleMesh mesh = LoadMesh(out + "/mesh.glb");
    size_t low_vertices = 0;
    for (const Eigen::Vector3f& v : mesh.vertices) low_vertices += v.z() < -0.1f ? 1 : 0;
    EXPECT_LT(low_vertices, mesh.vertices.size() / 100 + 1) << poses;
    const OccupancyGrid grid = ReadGrid(out + "/grid.yaml");
    EXPECT_TRUE(grid.world_from_grid.isApprox(Eigen::Isometry3d::Identity(), 1e-6)) << poses;
    EXPECT_EQ(testing::PhantomCells(grid, ReadCloud(out + "/map.ply")), 0u) << poses;
    const nlohmann::json report = nlohmann::json::parse(testing::ReadText(out + "/report.json"));
    EXPECT_EQ(report["map_frame"]["name"], "floor");
    EXPECT_TRUE(report["map_frame"]["floor_found"].get<bool>());
    EXPECT_NE(testing::ReadText(out + "/map.pcd").find("# frame: floor: z up"), std::string::npos);
  }
}

// map.frame=camera keeps the first camera's optical frame; map.frame=groundtruth with tracked
// poses anchors the map at the first frame's ground-truth pose.
TEST(BuildTest, TheOtherMapFramesAreTheFirstCameraAndTheGroundTruth) {
  testing::TempDir dir;
  WriteScenario(dir / "seq", "static", 30);
  const Trajectory truth = Trajectory::ReadTum(dir / "seq/groundtruth.txt");
  std::string output;
  for (const std::string frame : {"camera", "groundtruth"}) {
    const std::string out = dir / ("out_" + frame);
    std::string command = "build " + dir / "seq" + " -o " + out;
    command += " --detector none --quiet --set map.frame=" + frame;
    ASSERT_EQ(testing::RunStillmap(command, &output), 0) << output;
    const Trajectory written = Trajectory::ReadTum(out + "/trajectory.txt");
    const StampedPose& first = written.poses().front();
    const Eigen::Isometry3d expected =
        frame == "camera" ? Eigen::Isometry3d::Identity() : *truth.Interpolate(first.time, 0.1);
    EXPECT_TRUE(first.world_from_camera.isApprox(expected, 1e-6)) << frame;
    // The last pose is where the truth has it, up to the tracking's drift.
    const StampedPose& last = written.poses().back();
    if (frame == "groundtruth") {
      EXPECT_LT(
          (last.world_from_camera.translation() - truth.Interpolate(last.time, 0.1)->translation())
              .norm(),
          0.02);
    }
    const nlohmann::json report = nlohmann::json::parse(testing::ReadText(out + "/report.json"));
    EXPECT_EQ(report["map_frame"]["name"], frame);
  }
}

// Renders `frames` frames of the static room into DIR/seq and covers the lens (black color, no
// depth) for frames [first, end); returns the times of the covered frames.
std::vector<double> RenderWithCoveredLens(const std::string& dir, int frames, size_t first,
                                          size_t end) {
  WriteScenario(dir + "/seq", "static", frames);
  const Sequence sequence = Sequence::Open(dir + "/seq", ResolveCamera(dir + "/seq", {}));
  std::vector<double> covered;
  for (size_t i = first; i < end; ++i) {
    const FrameEntry& pair = sequence.frames()[i];
    cv::imwrite(pair.color_path, cv::Mat(480, 640, CV_8UC3, cv::Scalar(0, 0, 0)));
    cv::imwrite(pair.depth_path, cv::Mat(480, 640, CV_16UC1, cv::Scalar(0)));
    covered.push_back(pair.time);
  }
  return covered;
}

// A covered lens: frames whose images are black and depth empty get no pose (the trajectory skips
// them and the report names them), tracking resumes after them, and the run succeeds.
// A covered lens (no image, no depth) with the defaults: the motion model poses those frames and
// the report flags them.
TEST(BuildTest, TrackingRidesThroughACoveredLensAndFlagsIt) {
  testing::TempDir dir;
  const std::vector<double> covered = RenderWithCoveredLens(dir.path(), 30, 12, 15);
  std::string output;
  ASSERT_EQ(
      testing::RunStillmap("build " + dir / "seq" + " -o " + dir / "out" + " --quiet", &output), 0)
      << output;
  EXPECT_EQ(Trajectory::ReadTum(dir / "out/trajectory.txt").size(), 30u);
  const nlohmann::json report = nlohmann::json::parse(testing::ReadText(dir / "out/report.json"));
  EXPECT_EQ(report["tracking"]["lost"], 0);
  EXPECT_EQ(report["tracking"]["predicted"], 3);
  EXPECT_EQ(report["tracking"]["flagged_frame_times"].get<std::vector<double>>(), covered);
  EXPECT_EQ(report["tracking"]["static_depth_share"]["min"], 0.0);
}

// Without the motion model's ride-through, those frames get no pose.
TEST(BuildTest, TrackingWritesNoPoseForFramesItCannotTrack) {
  testing::TempDir dir;
  const std::vector<double> covered = RenderWithCoveredLens(dir.path(), 30, 12, 15);
  std::string output;
  ASSERT_EQ(testing::RunStillmap("build " + dir / "seq" + " -o " + dir / "out" +
                                     " --quiet --set tracking.max_predicted_frames=0",
                                 &output),
            0)
      << output;
  const Trajectory trajectory = Trajectory::ReadTum(dir / "out/trajectory.txt");
  EXPECT_EQ(trajectory.size(), 27u);
  for (const StampedPose& pose : trajectory.poses()) {
    for (double time : covered) EXPECT_NE(pose.time, time);
  }
  const nlohmann::json report = nlohmann::json::parse(testing::ReadText(dir / "out/report.json"));
  EXPECT_EQ(report["tracking"]["lost"], 3);
  EXPECT_EQ(report["tracking"]["relocalized"], 1);
  EXPECT_EQ(report["tracking"]["lost_frame_times"].get<std::vector<double>>(), covered);
}

// Nothing to track (every frame black, no depth): the run fails with exit 1 and a reason, and
// leaves no outputs.
TEST(BuildTest, TrackingNothingFailsWithoutOutputs) {
  testing::TempDir dir;
  RenderWithCoveredLens(dir.path(), 4, 0, 4);
  std::string output;
  EXPECT_EQ(
      testing::RunStillmap("build " + dir / "seq" + " -o " + dir / "out" + " --quiet", &output), 1);
  EXPECT_NE(output.find("no frame could be tracked"), std::string::npos) << output;
  EXPECT_FALSE(fs::exists(dir / "out"));
}

// Depth self-calibration on exact truth: the synthetic room's depth images rewritten as a sensor
// with a smooth error over the image would read them (z / (1 + delta(x, y)), delta about what
// Bonn's Xtion shows, up to 10 % at the corners). With the calibration the tracker finds its
// curvature and the trajectory comes back; without it the trajectory is bent.
TEST(BuildTest, DepthSelfCalibrationFindsAKnownDepthErrorOnASyntheticRoom) {
  testing::TempDir dir;
  WriteScenario(dir / "seq", "static", 150);
  const Camera camera = ResolveCamera(dir / "seq", {});
  DepthCorrection truth;
  truth.coefficients = {0.02, 0.04, 0.14, -0.08, 0.13};
  const cv::Mat factors = truth.FactorImage(camera);
  for (const auto& entry : fs::directory_iterator(dir / "seq/depth")) {
    cv::Mat depth = cv::imread(entry.path().string(), cv::IMREAD_UNCHANGED);
    ASSERT_EQ(depth.type(), CV_16UC1) << entry.path();
    cv::Mat raw;
    depth.convertTo(raw, CV_32F);
    raw /= factors;
    raw.convertTo(depth, CV_16U);  // rounds, saturates; 0 stays 0
    ASSERT_TRUE(cv::imwrite(entry.path().string(), depth));
  }
  const BuildResult calibrated = TrackRepeatably(
      dir / "seq", {"render.enabled=false", "tracking.depth_self_calibration=true"}, dir / "on");
  const BuildResult plain = TrackRepeatably(
      dir / "seq", {"render.enabled=false", "tracking.depth_self_calibration=false"});
  const nlohmann::json report = nlohmann::json::parse(testing::ReadText(dir / "on/report.json"));
  const nlohmann::json& calibration = report["tracking"]["depth_self_calibration"];
  ASSERT_GT(calibration["fits_accepted"].get<int>(), 0) << calibration.dump(2);
  DepthCorrection found;
  for (size_t i = 0; i < 5; ++i) found.coefficients[i] = calibration["coefficients"][i];
  // The curvature terms are found. The terms linear in x and y trade against a rotation of the
  // camera (z (1 + p y) is nearly a tilt), and the poses the fit starts from have absorbed part
  // of them: measured 0.041 and 0.115 for 0.02 and 0.04, so the depth error left over the image
  // is 2.1 % RMS of the 2.6 % there was, and the map (anchored at the first frame, so a tilt
  // counts) improves only from 43 to 39 mm. The trajectory, which is what the correction is for,
  // improves 3.3 times (42 -> 12.8 mm).
  for (size_t i = 2; i < 5; ++i) {
    EXPECT_NEAR(found.coefficients[i], truth.coefficients[i], 0.02) << "coefficient " << i;
  }
  double error_before = 0.0, error_after = 0.0;
  int samples = 0;
  for (int v = 0; v < camera.height; v += 8) {
    for (int u = 0; u < camera.width; u += 8) {
      const double x = (u - camera.cx) / camera.fx, y = (v - camera.cy) / camera.fy;
      error_before += std::pow(truth.Delta(x, y), 2);
      error_after += std::pow(found.Delta(x, y) - truth.Delta(x, y), 2);
      ++samples;
    }
  }
  error_before = std::sqrt(error_before / samples);
  error_after = std::sqrt(error_after / samples);
  ASSERT_TRUE(calibrated.AteRmse() && plain.AteRmse() && calibrated.evaluation.map_quality &&
              plain.evaluation.map_quality);
  std::cout << "synthetic room, depth bent by up to 10 %: depth error over the image (RMS) "
            << error_before * 100 << " -> " << error_after * 100 << " %, ATE "
            << *plain.AteRmse() * 1e3 << " -> " << *calibrated.AteRmse() * 1e3
            << " mm, map accuracy (median, anchored at the first frame) "
            << plain.evaluation.map_quality->accuracy_median * 1e3 << " -> "
            << calibrated.evaluation.map_quality->accuracy_median * 1e3 << " mm\n";
  EXPECT_LT(error_after, 0.9 * error_before);
  EXPECT_LT(*calibrated.AteRmse(), 0.4 * *plain.AteRmse());
  EXPECT_LT(calibrated.evaluation.map_quality->accuracy_median,
            plain.evaluation.map_quality->accuracy_median);
}

}  // namespace
}  // namespace stillmap
