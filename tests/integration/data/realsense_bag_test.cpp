// RealSense recorder bags (issue 49): teddy and bonn_crowd_a written in the layout librealsense's
// recorder writes (write_realsense_bag.py, with ROS's own Python writer: depth in a camera of its
// own 15 mm beside colour, Depth Units 0.2 mm, the extrinsics on tf/0) build with the ATE of
// their folders within 1 mm; `info` names the device; a recording without extrinsics, or with
// depth on another clock, is refused saying so; YUYV colour builds.
#include <gtest/gtest.h>

#include <cmath>
#include <nlohmann/json.hpp>

#include "test_util.h"

namespace stillmap {
namespace {

using testing::ReadText;
using testing::RunCommand;
using testing::RunStillmap;

// The writer needs Debian's Python (python3-rosbag and the message packages are installed for
// it by scripts/setup.sh), whatever python3 comes first on PATH.
std::string WriteBag(const std::string& folder, const std::string& bag, const std::string& extra) {
  std::string output;
  const int status = RunCommand(std::string("/usr/bin/python3 ") + STILLMAP_REALSENSE_WRITER + " " +
                                    folder + " " + bag + " " + extra,
                                &output);
  EXPECT_EQ(status, 0) << output;
  return bag;
}

double AteRmse(const std::string& groundtruth, const std::string& out) {
  std::string output;
  EXPECT_EQ(RunStillmap("eval " + groundtruth + " " + out + "/trajectory.txt --json", &output), 0)
      << output;
  return nlohmann::json::parse(output)["ate_m"]["rmse"].get<double>();
}

size_t Pairs(const std::string& out) {
  return nlohmann::json::parse(ReadText(out + "/report.json"))["frames"]["pairs_used"]
      .get<size_t>();
}

class RealSenseBagTest : public ::testing::Test {
 protected:
  // Builds the folder and its RealSense-layout bag with the same options.
  void BuildBoth(const std::string& name, const std::string& options) {
    const std::optional<std::string> folder = testing::SharedSequence(name);
    if (!folder) GTEST_SKIP() << name << " not in ../shared/data";
    const std::string bag = WriteBag(*folder, dir_ / (name + ".bag"), "");
    std::string output;
    ASSERT_EQ(
        RunStillmap("build " + bag + " -o " + (dir_ / "bag") + " --quiet " + options, &output), 0)
        << output;
    ASSERT_EQ(RunStillmap("build " + *folder + " -o " + (dir_ / "folder") + " --quiet " + options,
                          &output),
              0)
        << output;
    EXPECT_EQ(Pairs(dir_ / "bag"), Pairs(dir_ / "folder"));
    const double from_bag = AteRmse(*folder + "/groundtruth.txt", dir_ / "bag");
    const double from_folder = AteRmse(*folder + "/groundtruth.txt", dir_ / "folder");
    EXPECT_NEAR(from_bag, from_folder, 0.001) << "bag " << from_bag << " m, folder " << from_folder;
  }

  std::optional<std::string> Teddy() { return testing::SharedSequence("tum_fr3_teddy_200"); }

  testing::TempDir dir_;
};

TEST_F(RealSenseBagTest, TeddyBuildsLikeItsFolder) {
  BuildBoth("tum_fr3_teddy_200", "--detector none");
}

TEST_F(RealSenseBagTest, BonnCrowdBuildsLikeItsFolderWithTheDefaults) {
  BuildBoth("bonn_crowd_a", "");
}

TEST_F(RealSenseBagTest, InfoNamesTheDeviceAndTheStreamsABuildUses) {
  const std::optional<std::string> teddy = Teddy();
  if (!teddy) GTEST_SKIP() << "tum_fr3_teddy_200 not in ../shared/data";
  const std::string bag = WriteBag(*teddy, dir_ / "short.bag", "--frames 10");
  std::string output;
  ASSERT_EQ(RunStillmap("info " + bag, &output), 0) << output;
  EXPECT_NE(output.find("device: Intel RealSense D435 (serial 000000000001, firmware 5.13.0.50); "
                        "sensors: Stereo Module, RGB Camera"),
            std::string::npos)
      << output;
  EXPECT_NE(output.find("would use: colour /device_0/sensor_1/Color_0/image/data, depth "
                        "/device_0/sensor_0/Depth_0/image/data, camera "
                        "/device_0/sensor_1/Color_0/info/camera_info"),
            std::string::npos)
      << output;
}

TEST_F(RealSenseBagTest, DepthWithoutExtrinsicsIsRefusedNamingTheTopic) {
  const std::optional<std::string> teddy = Teddy();
  if (!teddy) GTEST_SKIP() << "tum_fr3_teddy_200 not in ../shared/data";
  const std::string bag = WriteBag(*teddy, dir_ / "no_tf.bag", "--frames 5 --omit-extrinsics");
  std::string output;
  EXPECT_EQ(RunStillmap("build " + bag + " -o " + (dir_ / "out") + " --detector none", &output), 2);
  EXPECT_NE(output.find("no extrinsic linking them (/device_0/sensor_0/Depth_0/tf/<group>)"),
            std::string::npos)
      << output;
  EXPECT_FALSE(std::filesystem::exists(dir_ / "out/map.ply"));
}

TEST_F(RealSenseBagTest, DepthOnAnotherClockSaysTheNearestGap) {
  const std::optional<std::string> teddy = Teddy();
  if (!teddy) GTEST_SKIP() << "tum_fr3_teddy_200 not in ../shared/data";
  const std::string bag =
      WriteBag(*teddy, dir_ / "clock.bag", "--frames 10 --depth-clock-offset 5");
  std::string output;
  EXPECT_EQ(RunStillmap("build " + bag + " -o " + (dir_ / "out") + " --detector none", &output), 2);
  // Ten colour frames span 0.3 s; depth starts 5 s later: at least 4.6 s apart.
  const size_t said = output.find("the nearest are ");
  ASSERT_NE(said, std::string::npos) << output;
  EXPECT_GT(std::stod(output.substr(said + 16)), 4.6) << output;
}

TEST_F(RealSenseBagTest, YuyvColourBuilds) {
  const std::optional<std::string> teddy = Teddy();
  if (!teddy) GTEST_SKIP() << "tum_fr3_teddy_200 not in ../shared/data";
  const std::string bag = WriteBag(*teddy, dir_ / "yuyv.bag", "--frames 10 --color-encoding yuyv");
  std::string output;
  ASSERT_EQ(RunStillmap("build " + bag + " -o " + (dir_ / "yuyv") + " --detector none", &output), 0)
      << output;
  const nlohmann::json report = nlohmann::json::parse(ReadText(dir_ / "yuyv/report.json"));
  EXPECT_EQ(report["frames"]["pairs_used"].get<size_t>(), 10u);
}

}  // namespace
}  // namespace stillmap
