// Recorded bags in (issue 28), through the binary: the shared ROS 1 and MCAP clips of
// tum_fr3_teddy_200
// (written by ROS's own writer, no camera.yaml) build like the folder's same frames; `info` names
// the topics a build would use; a bag cut short maps what it holds and says "truncated"; a topic
// that is not there is refused naming it and listing the bag's topics.
#include <gtest/gtest.h>

#include <filesystem>
#include <nlohmann/json.hpp>
#include <sstream>

#include "test_util.h"

namespace stillmap {
namespace {

namespace fs = std::filesystem;
using testing::ReadText;
using testing::RunStillmap;

nlohmann::json Report(const std::string& out) {
  return nlohmann::json::parse(ReadText(out + "/report.json"));
}

class BagBuildTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const std::optional<std::string> sequence = testing::SharedSequence("tum_fr3_teddy_200");
    if (!sequence) GTEST_SKIP() << "tum_fr3_teddy_200 not in ../shared/data";
    sequence_ = *sequence;
    groundtruth_ = sequence_ + "/groundtruth.txt";
  }

  // The folder's frames from the bag build's first frame on, as many as it used.
  std::string FolderBuild(const std::string& bag_out, const std::string& out) {
    std::istringstream trajectory(ReadText(bag_out + "/trajectory.txt"));
    std::string line;
    double first = 0.0;
    while (std::getline(trajectory, line)) {
      if (!line.empty() && line[0] != '#') {
        first = std::stod(line);
        break;
      }
    }
    std::istringstream rgb(ReadText(sequence_ + "/rgb.txt"));
    size_t index = 0;
    while (std::getline(rgb, line)) {
      if (line.empty() || line[0] == '#') continue;
      if (std::stod(line) >= first - 1e-4) break;
      ++index;
    }
    const size_t frames = Report(bag_out)["frames"]["pairs_used"].get<size_t>();
    std::string output;
    EXPECT_EQ(RunStillmap("build " + sequence_ + " -o " + out + " --quiet --detector none " +
                              "--set sequence.first_frame=" + std::to_string(index) +
                              " --set sequence.max_frames=" + std::to_string(frames),
                          &output),
              0)
        << output;
    return out;
  }

  std::string sequence_, groundtruth_;
  testing::TempDir dir_;
};

TEST_F(BagBuildTest, BagsBuildLikeTheFolder) {
  for (const char* name :
       {"teddy_tum_raw.bag", "teddy_realsense_lz4.bag", "teddy_realsense.mcap",
        "teddy_realsense_lz4_bgr.mcap", "teddy_realsense_db3", "teddy_tum_jazzy_db3"}) {
    const std::optional<std::string> bag = testing::SharedBag(name);
    if (!bag) GTEST_SKIP() << "bags/" << name << " not in ../shared/data";
    const std::string out = dir_ / (std::string(name) + ".out");
    std::string output;
    ASSERT_EQ(RunStillmap("build " + *bag + " -o " + out +
                              " --quiet --detector none --groundtruth " + groundtruth_,
                          &output),
              0)
        << output;
    const nlohmann::json from_bag = Report(out);
    const nlohmann::json from_folder = Report(FolderBuild(out, out + ".folder"));
    EXPECT_EQ(from_bag["frames"]["pairs_used"], from_folder["frames"]["pairs_used"]) << name;
    const double bag_ate = from_bag["trajectory_error"]["ate_m"]["rmse"].get<double>();
    const double folder_ate = from_folder["trajectory_error"]["ate_m"]["rmse"].get<double>();
    EXPECT_NEAR(bag_ate, folder_ate, 0.001) << name;
    const double bag_voxels = from_bag["map"]["voxels"].get<double>();
    const double folder_voxels = from_folder["map"]["voxels"].get<double>();
    EXPECT_NEAR(bag_voxels / folder_voxels, 1.0, 0.03) << name;
  }
}

TEST_F(BagBuildTest, InfoNamesTheTopicsABuildWouldUse) {
  const std::optional<std::string> bag = testing::SharedBag("teddy_realsense_lz4.bag");
  if (!bag) GTEST_SKIP() << "bags/teddy_realsense_lz4.bag not in ../shared/data";
  std::string output;
  ASSERT_EQ(RunStillmap("info " + *bag, &output), 0) << output;
  EXPECT_NE(output.find("would use: colour /camera/camera/color/image_raw/compressed, depth "
                        "/camera/camera/aligned_depth_to_color/image_raw, camera "
                        "/camera/camera/color/camera_info"),
            std::string::npos)
      << output;
  EXPECT_NE(output.find("sensor_msgs/CompressedImage"), std::string::npos) << output;
}

TEST_F(BagBuildTest, ABagCutShortMapsWhatItHoldsAndSaysTruncated) {
  const std::optional<std::string> bag = testing::SharedBag("teddy_realsense_lz4.bag");
  if (!bag) GTEST_SKIP() << "bags/teddy_realsense_lz4.bag not in ../shared/data";
  const std::string cut = dir_ / "cut.bag";
  fs::copy_file(*bag, cut);
  fs::resize_file(cut, fs::file_size(*bag) * 6 / 10);
  std::string output;
  ASSERT_EQ(
      RunStillmap("build " + cut + " -o " + (dir_ / "out") + " --quiet --detector none", &output),
      0)
      << output;
  EXPECT_NE(output.find("truncated"), std::string::npos) << output;
  const nlohmann::json report = Report(dir_ / "out");
  EXPECT_GT(report["frames"]["pairs_used"].get<int>(), 5);
  EXPECT_LT(report["frames"]["pairs_used"].get<int>(), 30);
}

TEST_F(BagBuildTest, AMissingTopicIsRefusedListingTheBagsTopics) {
  const std::optional<std::string> bag = testing::SharedBag("teddy_tum_raw.bag");
  if (!bag) GTEST_SKIP() << "bags/teddy_tum_raw.bag not in ../shared/data";
  std::string output;
  EXPECT_EQ(RunStillmap("build " + *bag + " -o " + (dir_ / "out") +
                            " --quiet --topic depth=/camera/depth_registered/image_raw",
                        &output),
            2)
      << output;
  EXPECT_NE(output.find("/camera/depth_registered/image_raw"), std::string::npos) << output;
  EXPECT_NE(output.find("/camera/rgb/image_color"), std::string::npos) << output;
  EXPECT_FALSE(fs::exists(dir_ / "out"));
  EXPECT_EQ(
      RunStillmap("build " + *bag + " -o " + (dir_ / "out") + " --quiet --topic rgb=/x", &output),
      2)
      << output;
  EXPECT_NE(output.find("--topic"), std::string::npos) << output;
}

}  // namespace
}  // namespace stillmap
