// Poses from the robot (issue 48), through the binary: a bag's /tf tree and odometry and a
// trajectory file as the map's poses, as the tracker's prior through a blackout, and the map in
// the poses' world. The bags are written by ../shared/tools/make-bags from the shared sequences'
// ground truth; the tests skip when the data or the tool is absent.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <vector>

#include "stillmap/io/cloud_files.h"
#include "stillmap/io/trajectory.h"
#include "test_util.h"

namespace stillmap {
namespace {

namespace fs = std::filesystem;

nlohmann::json Report(const std::string& out) {
  return nlohmann::json::parse(testing::ReadText(out + "/report.json"));
}

// The largest distance between the positions of two trajectories at the same stamps [m]; both
// must hold the same stamps.
double LargestGap(const Trajectory& a, const Trajectory& b) {
  EXPECT_EQ(a.size(), b.size());
  double gap = 0.0;
  for (size_t i = 0; i < std::min(a.size(), b.size()); ++i) {
    EXPECT_NEAR(a.poses()[i].time, b.poses()[i].time, 1e-6);
    gap = std::max(gap, (a.poses()[i].world_from_camera.translation() -
                         b.poses()[i].world_from_camera.translation())
                            .norm());
  }
  return gap;
}

// Teddy's first 60 frames as a ROS 1 bag, a ROS 2 sqlite3 bag and an MCAP file, each with
// /tf, /tf_static and /odom from the ground truth, made once for the suite.
class GivenPosesTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    teddy_ = testing::SharedSequence("tum_fr3_teddy_200");
    make_bags_ = testing::SharedTool("make-bags");
    if (!teddy_ || !make_bags_) return;
    dir_ = std::make_unique<testing::TempDir>();
    for (const char* format : {"bag", "db3", "mcap"}) {
      std::string output;
      const std::string bag = *dir_ / (std::string("teddy.") + format);
      ASSERT_EQ(testing::RunCommand(*make_bags_ + " " + *teddy_ + " " + bag + " --format " +
                                        format + " --count 60 --poses both",
                                    &output),
                0)
          << output;
    }
  }
  static void TearDownTestSuite() { dir_.reset(); }
  void SetUp() override {
    if (!teddy_ || !make_bags_)
      GTEST_SKIP() << "needs ../shared/data and ../shared/tools/make-bags";
  }
  // `stillmap build BAG -o OUT --detector none --quiet EXTRA`; its exit status and output.
  static int Build(const std::string& input, const std::string& out, const std::string& extra,
                   std::string* output) {
    return testing::RunStillmap(
        "build " + input + " -o " + out + " --detector none --quiet " + extra, output);
  }
  static std::string Groundtruth() { return *teddy_ + "/groundtruth.txt"; }

  static std::optional<std::string> teddy_, make_bags_;
  static std::unique_ptr<testing::TempDir> dir_;
};
std::optional<std::string> GivenPosesTest::teddy_, GivenPosesTest::make_bags_;
std::unique_ptr<testing::TempDir> GivenPosesTest::dir_;

// Every frame fused, in the ground truth's world, so that the runs compare pose by pose.
const char* const kEveryFrame =
    " --set poses.keyframe_distance_m=0 --set poses.keyframe_angle_deg=0"
    " --set map.frame=groundtruth";

TEST_F(GivenPosesTest, TfAndOdometryOfEveryBagFormatGiveTheGroundTruthsMap) {
  testing::TempDir work;
  std::string output;
  const std::string gt = " --groundtruth " + Groundtruth();
  ASSERT_EQ(
      Build(*dir_ / "teddy.bag", work / "gt", "--poses groundtruth" + gt + kEveryFrame, &output), 0)
      << output;
  const Trajectory reference = Trajectory::ReadTum(work / "gt/trajectory.txt");
  const double reference_voxels = Report(work / "gt")["map"]["voxels_written"].get<double>();
  std::optional<Trajectory> first;
  std::optional<double> first_voxels;
  for (const char* format : {"bag", "db3", "mcap"}) {
    for (const char* poses : {"tf:odom", "odom:/odom"}) {
      SCOPED_TRACE(std::string(format) + " " + poses);
      const std::string out = work / (std::string(format) + "_" + (poses[0] == 't' ? "tf" : "od"));
      ASSERT_EQ(Build(*dir_ / (std::string("teddy.") + format), out,
                      std::string("--poses ") + poses + gt + kEveryFrame, &output),
                0)
          << output;
      // make-bags writes qw again from the ground truth's 4-digit x y z (the file's quaternions
      // are normalized instead): positions 0.1 mm apart at most, orientations up to half a
      // degree where w is near 0, and so the voxels within 1 %.
      const Trajectory trajectory = Trajectory::ReadTum(out + "/trajectory.txt");
      EXPECT_LT(LargestGap(reference, trajectory), 1e-4);
      const nlohmann::json report = Report(out);
      const double voxels = report["map"]["voxels_written"].get<double>();
      EXPECT_NEAR(voxels / reference_voxels, 1.0, 0.01);
      // Every format, and /tf or /odom alike, give the same poses and the same map.
      if (!first) first = trajectory, first_voxels = voxels;
      EXPECT_LT(LargestGap(*first, trajectory), 1e-9);
      EXPECT_EQ(voxels, *first_voxels);
      EXPECT_EQ(report["poses"], "given");
      EXPECT_EQ(report["given_poses"]["source"], poses);
      EXPECT_EQ(report["given_poses"]["world_frame"], "odom");
      EXPECT_NE(report["given_poses"]["from"].get<std::string>().find(
                    "odom -> base_link -> openni_rgb_optical_frame"),
                std::string::npos);
      // The first frames come before the motion capture's first pose: counted, not mapped.
      EXPECT_EQ(report["given_poses"]["frames_without_pose"]["before_the_poses"],
                report["frames"]["without_pose"]);
    }
  }
  // The ground truth given as a file on the folder.
  ASSERT_EQ(Build(*teddy_, work / "file",
                  "--set sequence.max_frames=60 --poses " + Groundtruth() + kEveryFrame, &output),
            0)
      << output;
  ASSERT_EQ(
      Build(*teddy_, work / "folder_gt",
            "--set sequence.max_frames=60 --poses groundtruth" + std::string(kEveryFrame), &output),
      0)
      << output;
  EXPECT_LT(LargestGap(Trajectory::ReadTum(work / "folder_gt/trajectory.txt"),
                       Trajectory::ReadTum(work / "file/trajectory.txt")),
            1e-9);
}

TEST_F(GivenPosesTest, WrongFramesTopicsAndStampsAreRefusedWithWhatTheBagHolds) {
  testing::TempDir work;
  std::string output;
  const std::string bag = *dir_ / "teddy.mcap";
  EXPECT_EQ(Build(bag, work / "a", "--poses tf:map", &output), 2) << output;
  EXPECT_NE(output.find("frame 'map' is not in the transform tree; its frames are: base_link, "
                        "odom, openni_rgb_optical_frame"),
            std::string::npos)
      << output;
  EXPECT_EQ(Build(bag, work / "b", "--poses odom:/wheel_odom", &output), 2) << output;
  EXPECT_NE(output.find("its odometry topics: /odom"), std::string::npos) << output;
  EXPECT_EQ(Build(*teddy_, work / "c", "--poses tf:odom", &output), 2) << output;
  EXPECT_NE(output.find("is a folder, not a recorded bag"), std::string::npos) << output;
  // A trajectory 1000 s after the images: where each lies, and by how much.
  std::ifstream in(Groundtruth());
  std::string line, shifted;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    const size_t space = line.find(' ');
    shifted +=
        std::to_string(std::stod(line.substr(0, space)) + 1000.0) + line.substr(space) + "\n";
  }
  testing::WriteText(work / "late.txt", shifted);
  EXPECT_EQ(Build(bag, work / "d", "--poses " + work / "late.txt", &output), 2) << output;
  EXPECT_NE(output.find("no frame has a pose"), std::string::npos) << output;
  EXPECT_NE(output.find("frames before them, by up to 100"), std::string::npos) << output;
  EXPECT_FALSE(fs::exists(work / "d/map.ply"));
  EXPECT_EQ(Build(bag, work / "e", "--set map.frame=poses", &output), 2) << output;
  EXPECT_NE(output.find("map.frame=poses puts the map in the given poses' world"),
            std::string::npos)
      << output;
}

TEST_F(GivenPosesTest, AMapFromGivenPosesMergesWithATrackedOneLikeAnyOther) {
  testing::TempDir work;
  std::string output;
  const std::string bag = *dir_ / "teddy.db3";
  ASSERT_EQ(Build(bag, work / "given", "--poses odom:/odom", &output), 0) << output;
  ASSERT_EQ(Build(bag, work / "tracked", "", &output), 0) << output;
  ASSERT_TRUE(fs::exists(work / "given/session.bin"));
  ASSERT_EQ(testing::RunStillmap("merge " + work / "given" + " " + work / "tracked" + " -o " +
                                     work / "merged" + " --quiet",
                                 &output),
            0)
      << output;
  const nlohmann::json merged = Report(work / "merged");
  ASSERT_EQ(merged["sessions"].size(), 2u);
  for (const nlohmann::json& session : merged["sessions"]) {
    EXPECT_TRUE(session["joined"].get<bool>()) << session["name"];
    EXPECT_GE(session["keyframes"].get<int>(), 3) << session["name"];
  }
  EXPECT_NE(testing::ReadText(work / "given/session.bin")
                .find("\"poses\":\"odom:/odom, the map's poses\""),
            std::string::npos);
}

// Overwrites the rotation of the first `count` poses of base_link in a ROS 1 bag (/tf and /odom
// alike: the frame name, then its pose) with NaN.
void BreakTransforms(const std::string& path, int count) {
  std::fstream file(path, std::ios::in | std::ios::out | std::ios::binary);
  std::string bytes((std::istreambuf_iterator<char>(file)), std::istreambuf_iterator<char>());
  const std::string child = std::string("\x0a\x00\x00\x00", 4) + "/base_link";
  size_t at = 0;
  for (int broken = 0; broken < count; ++broken) {
    do {  // not /tf_static's, where the frame is the parent and the child's name follows
      at = bytes.find(child, at + 1);
      ASSERT_NE(at, std::string::npos);
    } while (bytes[at + child.size() + 4] == '/');
    const double nan = std::nan("");
    file.seekp(static_cast<std::streamoff>(at + child.size() + 3 * sizeof(double)));
    file.write(reinterpret_cast<const char*>(&nan), sizeof(nan));
  }
}

TEST_F(GivenPosesTest, ABagCutShortOrWithBrokenTransformsMapsWhatItCanAndSaysWhatItSkipped) {
  testing::TempDir work;
  std::string output;
  fs::copy_file(*dir_ / "teddy.bag", work / "broken.bag");
  BreakTransforms(work / "broken.bag", 40);
  ASSERT_EQ(Build(work / "broken.bag", work / "broken", "--poses tf:odom", &output), 0) << output;
  const nlohmann::json broken = Report(work / "broken");
  EXPECT_NE(broken["warnings"].dump().find("is not a rigid motion"), std::string::npos)
      << broken["warnings"];
  EXPECT_GT(broken["frames"]["fused"].get<int>(), 0);
  // Cut at two thirds: the frames and poses before the cut are mapped.
  const auto size = fs::file_size(*dir_ / "teddy.bag");
  fs::copy_file(*dir_ / "teddy.bag", work / "cut.bag");
  fs::resize_file(work / "cut.bag", size * 2 / 3);
  ASSERT_EQ(Build(work / "cut.bag", work / "cut", "--poses odom:/odom", &output), 0) << output;
  const nlohmann::json cut = Report(work / "cut");
  EXPECT_NE(cut["warnings"].dump().find("truncated"), std::string::npos) << cut["warnings"];
  EXPECT_GT(cut["frames"]["fused"].get<int>(), 0);
}

// A plane 2 m before the first camera, seen by a camera carried on a body: the map's points,
// in the poses' world (map.frame=poses), lie on the plane where the world has it.
TEST(GivenPosesFrameTest, MapFramePosesPutsThePointsWhereThePosesWorldHasThem) {
  testing::TempDir dir;
  const Camera camera = testing::SmallCamera(160, 120);
  std::vector<Eigen::Isometry3d> world_from_camera;
  for (int k = 0; k < 12; ++k) {
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.translation() = Eigen::Vector3d(0.02 * k, 0.01 * k, 0.0);
    world_from_camera.push_back(pose);
  }
  testing::PlaneScene scene;  // z = 2 m in the world
  const Trajectory truth =
      testing::WritePlaneSequence(dir / "seq", camera, scene, world_from_camera);
  // The robot's body: the camera 0.3 m above and 0.1 m ahead of it, turned 90 degrees (optical z
  // along the body's x); the file holds the body's poses.
  Eigen::Isometry3d body_from_camera = Eigen::Isometry3d::Identity();
  body_from_camera.linear() << 0, 0, 1, -1, 0, 0, 0, -1, 0;
  body_from_camera.translation() << 0.1, 0.0, 0.3;
  std::vector<StampedPose> body;
  for (const StampedPose& pose : truth.poses()) {
    body.push_back({pose.time, pose.world_from_camera * body_from_camera.inverse()});
  }
  Trajectory(body).WriteTum(dir / "body.txt");
  std::string matrix;
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c)
      matrix += (matrix.empty() ? "" : ",") + std::to_string(body_from_camera.matrix()(r, c));
  }
  std::string output;
  ASSERT_EQ(testing::RunStillmap("build " + dir / "seq" + " -o " + dir / "out" + " --poses " +
                                     dir / "body.txt" + " --set poses.body_from_camera=" + matrix +
                                     " --set map.frame=poses --detector none --quiet",
                                 &output),
            0)
      << output;
  const std::vector<VoxelPoint> cloud = ReadCloud(dir / "out/map.ply");
  ASSERT_GT(cloud.size(), 100u);
  for (const VoxelPoint& point : cloud) {
    ASSERT_NEAR(point.position.z(), 2.0, 0.02) << point.position.transpose();
  }
  // The trajectory is the given one, in the same world.
  const Trajectory written = Trajectory::ReadTum(dir / "out/trajectory.txt");
  ASSERT_EQ(written.size(), truth.size());
  for (size_t i = 0; i < truth.size(); ++i) {
    EXPECT_TRUE(
        written.poses()[i].world_from_camera.isApprox(truth.poses()[i].world_from_camera, 1e-5));
  }
  const nlohmann::json report = Report(dir / "out");
  EXPECT_EQ(report["map_frame"]["name"], "poses");
  EXPECT_NE(testing::ReadText(dir / "out/grid.yaml").find("origin"), std::string::npos);
}

// bonn_crowd_a with 60 frames in the middle black and without depth, the robot's odometry
// drifting 2 %: the tracker alone loses the camera there; with the odometry as its prior, no
// frame is lost and the trajectory holds (issue 48's figures).
TEST(GivenPosesPriorTest, TheOdometryCarriesTheTrackerThroughABlackout) {
  const std::optional<std::string> bonn = testing::SharedSequence("bonn_crowd_a");
  const std::optional<std::string> make_bags = testing::SharedTool("make-bags");
  if (!bonn || !make_bags) GTEST_SKIP() << "needs ../shared/data/bonn_crowd_a and make-bags";
  testing::TempDir dir;
  const std::string copy = dir / "bonn_black";
  fs::create_directories(copy + "/rgb");
  fs::create_directories(copy + "/depth");
  for (const char* name : {"rgb.txt", "depth.txt", "groundtruth.txt", "camera.yaml"}) {
    fs::copy_file(*bonn + "/" + name, copy + "/" + name);
  }
  for (const char* list : {"rgb.txt", "depth.txt"}) {
    std::ifstream in(*bonn + "/" + list);
    std::string line;
    int index = 0;
    while (std::getline(in, line)) {
      if (line.empty() || line[0] == '#') continue;
      const std::string file = line.substr(line.find(' ') + 1);
      if (index >= 280 && index < 340) {
        cv::Mat image = cv::imread(*bonn + "/" + file, cv::IMREAD_UNCHANGED);
        image.setTo(0);
        cv::imwrite(copy + "/" + file, image);
      } else {
        fs::create_symlink(*bonn + "/" + file, copy + "/" + file);
      }
      ++index;
    }
  }
  std::string output;
  ASSERT_EQ(testing::RunCommand(*make_bags + " " + copy + " " + dir / "black.bag" +
                                    " --format bag --poses tf --drift 2",
                                &output),
            0)
      << output;
  const std::string common = " --detector none --quiet --groundtruth " + *bonn + "/groundtruth.txt";
  ASSERT_EQ(
      testing::RunStillmap("build " + dir / "black.bag" + " -o " + dir / "alone" + common, &output),
      0)
      << output;
  ASSERT_EQ(testing::RunStillmap("build " + dir / "black.bag" + " -o " + dir / "prior" + common +
                                     " --poses tf:odom --set poses.use=prior",
                                 &output),
            0)
      << output;
  const nlohmann::json alone = Report(dir / "alone"), prior = Report(dir / "prior");
  EXPECT_GT(alone["tracking"]["lost"].get<int>(), 0);
  EXPECT_EQ(prior["tracking"]["lost"], 0);
  EXPECT_EQ(prior["tracking"]["new_maps"], 0);
  EXPECT_GE(prior["tracking"]["carried_by_given_poses"].get<int>(), 55);
  EXPECT_EQ(prior["given_poses"]["use"], "prior");
  const double ate = prior["trajectory_error"]["ate_m"]["rmse"].get<double>();
  std::cout << "blackout: ATE " << ate * 1e3 << " mm with the prior, "
            << alone["trajectory_error"]["ate_m"]["rmse"].get<double>() * 1e3 << " mm alone, "
            << alone["tracking"]["lost"] << " frames lost alone\n";
  EXPECT_LE(ate, 0.025);
}

}  // namespace
}  // namespace stillmap
