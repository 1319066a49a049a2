// Every bad input of issue 2 through the real binary: one clear line naming the culprit, exit
// status 2, and no output left behind.
#include <gtest/gtest.h>

#include <filesystem>
#include <opencv2/imgcodecs.hpp>

#include "test_util.h"

namespace stillmap {
namespace {

namespace fs = std::filesystem;
using testing::ReadText;
using testing::RunStillmap;
using testing::TempDir;
using testing::WriteText;

class BadInputTest : public testing::SmallSequenceTest {
 protected:
  // Runs `build` and checks the contract: exit 2, a single "stillmap: error:" line mentioning
  // `expected`, and no output folder (it did not exist before).
  void ExpectRefused(const std::string& expected, const std::string& extra = "") {
    std::string output;
    const int status = RunStillmap(
        "build " + sequence_ + " -o " + output_ + " --poses groundtruth --quiet " + extra, &output);
    EXPECT_EQ(status, 2) << output;
    EXPECT_NE(output.find("stillmap: error: "), std::string::npos) << output;
    EXPECT_NE(output.find(expected), std::string::npos)
        << "expected '" << expected << "' in: " << output;
    EXPECT_EQ(std::count(output.begin(), output.end(), '\n'), 1) << output;
    EXPECT_FALSE(fs::exists(output_)) << "outputs left behind in " << output_;
  }

  std::string FirstListedDepth() {
    const std::string list = ReadText(sequence_ + "/depth.txt");
    const size_t line = list.find("depth/");
    return sequence_ + "/" + list.substr(line, list.find('\n', line) - line);
  }
};

TEST_F(BadInputTest, TheGoodSequenceBuilds) {
  std::string output;
  EXPECT_EQ(RunStillmap("build " + sequence_ + " -o " + output_ + " --poses groundtruth --quiet",
                        &output),
            0)
      << output;
  EXPECT_TRUE(fs::exists(output_ + "/map.ply"));
}

// stillmap merge refuses what it cannot join before it writes anything: folders without a session
// record (a build with known poses writes none), a damaged record, a single session, the output
// in a session's folder.
TEST_F(BadInputTest, MergeRefusesFoldersItCannotJoin) {
  std::string output;
  const std::string a = dir_ / "a", b = dir_ / "b", merged = dir_ / "merged";
  for (const std::string& out : {a, b}) {
    ASSERT_EQ(
        RunStillmap("build " + sequence_ + " -o " + out + " --poses groundtruth --quiet", &output),
        0)
        << output;
  }
  auto expect_refused = [&](const std::string& arguments, const std::string& expected) {
    EXPECT_EQ(RunStillmap("merge " + arguments + " --quiet", &output), 2) << output;
    EXPECT_NE(output.find("stillmap: error: "), std::string::npos) << output;
    EXPECT_NE(output.find(expected), std::string::npos)
        << "expected '" << expected << "' in: " << output;
    EXPECT_FALSE(fs::exists(merged)) << "outputs left behind";
  };
  expect_refused(a + " " + b + " -o " + merged, a + "/session.bin: missing");
  expect_refused(a + " " + (dir_ / "nowhere") + " -o " + merged, "nowhere: no such folder");
  expect_refused(a + " -o " + merged, "at least two session folders");
  WriteText(a + "/session.bin", "stillmap-sessionxxxx");
  WriteText(b + "/session.bin", "not a record");
  expect_refused(a + " " + b + " -o " + merged, a + "/session.bin: damaged session record");
  expect_refused(b + " " + a + " -o " + merged, b + "/session.bin: not a stillmap session record");
  expect_refused(a + " " + b + " -o " + a, "the output folder is the session");
  expect_refused(a + " " + a + " -o " + merged, "the same folder as");
}

TEST_F(BadInputTest, MissingSequenceFolder) {
  sequence_ = dir_ / "nowhere";
  ExpectRefused("sequence folder not found");
}

TEST_F(BadInputTest, MissingRgbList) {
  fs::remove(sequence_ + "/rgb.txt");
  ExpectRefused("no rgb.txt in the folder");
}

TEST_F(BadInputTest, EmptyDepthList) {
  WriteText(sequence_ + "/depth.txt", "# nothing here\n");
  ExpectRefused("depth.txt: the file list names no images");
}

TEST_F(BadInputTest, ImageListedButMissing) {
  fs::remove(FirstListedDepth());
  ExpectRefused("cannot open the image listed in the sequence: no such file");
}

TEST_F(BadInputTest, TruncatedPng) {
  const std::string depth = FirstListedDepth();
  fs::resize_file(depth, fs::file_size(depth) / 2);
  ExpectRefused("truncated PNG");
}

TEST_F(BadInputTest, TruncatedPngLateInTheSequenceLeavesNoOutputs) {
  const std::string list = ReadText(sequence_ + "/depth.txt");
  const size_t last = list.rfind("depth/");
  const std::string depth = sequence_ + "/" + list.substr(last, list.find('\n', last) - last);
  fs::resize_file(depth, fs::file_size(depth) - 20);
  ExpectRefused("truncated PNG");
}

TEST_F(BadInputTest, EightBitDepth) {
  cv::imwrite(FirstListedDepth(), cv::Mat(48, 64, CV_8UC1, cv::Scalar(100)));
  ExpectRefused("8 bits");
}

TEST_F(BadInputTest, UnsortedTimestamps) {
  WriteText(sequence_ + "/rgb.txt",
            "1000.033333 rgb/1000.033333.png\n1000.000000 rgb/1000.000000.png\n");
  ExpectRefused("rgb.txt:2: timestamp");
}

TEST_F(BadInputTest, DuplicateTimestamps) {
  WriteText(sequence_ + "/depth.txt",
            "1000.000000 depth/1000.000000.png\n1000.000000 depth/1000.033333.png\n");
  ExpectRefused("repeats");
}

TEST_F(BadInputTest, NoPairWithinTheWindow) {
  WriteText(sequence_ + "/depth.txt", "1005.0 depth/1000.000000.png\n");
  ExpectRefused("no color image has a depth image within");
}

TEST_F(BadInputTest, NanInGroundTruth) {
  WriteText(sequence_ + "/groundtruth.txt", "1000 0 0 0 0 0 0 1\n1000.1 0 0 nan 0 0 0 1\n");
  ExpectRefused("groundtruth.txt:2");
}

TEST_F(BadInputTest, NonUnitQuaternionInGroundTruth) {
  WriteText(sequence_ + "/groundtruth.txt", "1000 0 0 0 0 0 0.5 0.5\n");
  ExpectRefused("expected 1");
}

TEST_F(BadInputTest, CameraFileWithAMissingKey) {
  std::string camera = ReadText(sequence_ + "/camera.yaml");
  camera.erase(camera.find("cy:"), camera.find('\n', camera.find("cy:")) - camera.find("cy:") + 1);
  WriteText(sequence_ + "/camera.yaml", camera);
  ExpectRefused("missing key 'cy'");
}

TEST_F(BadInputTest, NoCameraAtAll) {
  fs::remove(sequence_ + "/camera.yaml");
  ExpectRefused("camera.preset");
}

TEST_F(BadInputTest, SetOfAnUnknownKey) {
  ExpectRefused("unknown configuration key 'mapping.leaf'", "--set mapping.leaf=0.02");
}

TEST_F(BadInputTest, ImpossibleValue) {
  ExpectRefused("mapping.voxel_leaf_size", "--set mapping.voxel_leaf_size=-1");
}

TEST_F(BadInputTest, OutputFolderThatCannotBeWritten) {
  WriteText(dir_ / "a_file", "x");
  output_ = dir_ / "a_file/out";
  ExpectRefused("cannot create the output folder");
}

TEST_F(BadInputTest, UnknownDetectorIsRefused) {
  std::string output;
  EXPECT_EQ(
      RunStillmap("build " + sequence_ + " -o " + output_ + " --detector yolo9 --quiet", &output),
      2);
  EXPECT_NE(output.find("yolo9"), std::string::npos) << output;
  EXPECT_FALSE(std::filesystem::exists(output_));
}

TEST_F(BadInputTest, DetectorWithoutItsModelIsRefusedNamingTheFile) {
  ExpectRefused("yolox_nano.onnx", "--detector yolox --models " + (dir_ / "no_models"));
}

TEST_F(BadInputTest, UnknownOutlineModeIsRefused) {
  ExpectRefused("masking.outline", "--set masking.outline=blob");
}

TEST_F(BadInputTest, UnknownPlanarMotionModeIsRefused) {
  ExpectRefused("tracking.planar_motion", "--set tracking.planar_motion=sometimes");
}

TEST_F(BadInputTest, ImpossibleFloorTiltOptionsAreRefused) {
  ExpectRefused("tracking.planar_motion_floor_max_angle_deg",
                "--set tracking.planar_motion_floor_max_angle_deg=0");
  ExpectRefused("tracking.planar_motion_floor_min_keyframes",
                "--set tracking.planar_motion_floor_min_keyframes=400");
}

TEST_F(BadInputTest, BadMotionLevelIsRefused) {
  ExpectRefused("detector.levels", "--set detector.levels=chair=sometimes");
}

TEST(CommandLineTest, UsageErrorsExitWithTwoAndHelpWithZero) {
  std::string output;
  EXPECT_EQ(RunStillmap("", &output), 2);
  EXPECT_EQ(RunStillmap("build", &output), 2);
  EXPECT_EQ(RunStillmap("frobnicate", &output), 2);
  EXPECT_EQ(RunStillmap("--version", &output), 0);
  EXPECT_NE(output.find("stillmap 0."), std::string::npos);
  for (const char* command : {"build", "eval", "info"}) {
    EXPECT_EQ(RunStillmap(std::string(command) + " --help", &output), 0) << command;
    EXPECT_NE(output.find("Usage"), std::string::npos) << output;
  }
}

}  // namespace
}  // namespace stillmap
