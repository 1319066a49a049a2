// Issue 15's cases through the real binary: output folders are never lost or mixed, empty results
// and wild inputs end with one clear line and a non-zero exit, never a crash, a hang or a set of
// files that looks finished.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <sstream>

#include "test_util.h"

namespace stillmap {
namespace {

namespace fs = std::filesystem;
using testing::ReadText;
using testing::RunStillmap;
using testing::TempDir;
using testing::WriteText;

// A plane seen by a small camera from four ground-truth poses.
class ReliabilityTest : public testing::SmallSequenceTest {
 protected:
  // Exit `status`, the last line "stillmap: <kind>: ..." holding `expected`, and no output folder.
  void ExpectFailure(int status, const std::string& expected, const std::string& extra = "") {
    std::string output;
    EXPECT_EQ(Build(extra, &output), status) << output;
    const std::string kind = status == 2 ? "stillmap: error: " : "stillmap: failed: ";
    EXPECT_NE(output.find(kind), std::string::npos) << output;
    EXPECT_NE(output.find(expected), std::string::npos) << "'" << expected << "' not in " << output;
    EXPECT_FALSE(fs::exists(output_)) << "outputs left in " << output_ << "\n" << output;
  }

  std::vector<std::string> Listed(const std::string& list) {
    std::vector<std::string> paths;
    std::istringstream lines(ReadText(sequence_ + "/" + list));
    for (std::string line; std::getline(lines, line);) {
      if (!line.empty() && line[0] != '#')
        paths.push_back(sequence_ + "/" + line.substr(line.find(' ') + 1));
    }
    return paths;
  }

  void WriteCameraLine(const std::string& key, const std::string& value) {
    std::string camera = ReadText(sequence_ + "/camera.yaml");
    const size_t at = camera.find(key + ":");
    camera.replace(at, camera.find('\n', at) - at, key + ": " + value);
    WriteText(sequence_ + "/camera.yaml", camera);
  }
};

// ---- Output folders -----------------------------------------------------------------------------

TEST_F(ReliabilityTest, SynthIntoAFolderNamedWithATrailingSlashKeepsEverythingElse) {
  std::string output;
  const std::string target = dir_ / "synth/";
  ASSERT_EQ(RunStillmap("synth " + target + " --scenario static --frames 3", &output), 0) << output;
  fs::create_directories(target + "out");
  WriteText(target + "out/map.ply", "a build the user kept");
  WriteText(target + "notes.txt", "notes");
  ASSERT_EQ(RunStillmap("synth " + target + " --scenario walking_xyz --frames 4", &output), 0)
      << output;
  EXPECT_EQ(ReadText(target + "notes.txt"), "notes");
  EXPECT_EQ(ReadText(target + "out/map.ply"), "a build the user kept");
  EXPECT_NE(ReadText(target + "synth.json").find("walking_xyz"), std::string::npos);
  // "synth ." from inside it, as well.
  ASSERT_EQ(RunStillmap("synth . --scenario static --frames 3", &output, "cd " + target + " &&"), 0)
      << output;
  EXPECT_EQ(ReadText(target + "notes.txt"), "notes");
  EXPECT_NE(ReadText(target + "synth.json").find("\"static\""), std::string::npos);
}

TEST_F(ReliabilityTest, SynthRefusesAFolderOfOtherFiles) {
  std::string output;
  fs::create_directories(dir_ / "mine");
  WriteText(dir_ / "mine/thesis.tex", "precious");
  EXPECT_EQ(RunStillmap("synth " + (dir_ / "mine/") + " --scenario static --frames 3", &output), 2);
  EXPECT_NE(output.find("not an earlier stillmap synth output"), std::string::npos) << output;
  EXPECT_EQ(ReadText(dir_ / "mine/thesis.tex"), "precious");
}

TEST_F(ReliabilityTest, ARerunReplacesTheWholeSet) {
  std::string output;
  ASSERT_EQ(Build("", &output), 0) << output;
  ASSERT_TRUE(fs::exists(output_ + "/grid.pgm"));
  WriteText(output_ + "/notes.txt", "mine");
  ASSERT_EQ(Build("--set octomap.enabled=false", &output), 0) << output;
  for (const char* stale : {"grid.pgm", "grid.yaml", "map.bt", "map.ot"}) {
    EXPECT_FALSE(fs::exists(output_ + "/" + stale)) << stale << " of the earlier run stayed";
  }
  EXPECT_EQ(ReadText(output_ + "/notes.txt"), "mine");
  // The user's file is named, and what the OctoMap's absence leaves out is said.
  EXPECT_NE(output.find("files stillmap did not write, left as they are: notes.txt"),
            std::string::npos)
      << output;
  EXPECT_NE(output.find("the OctoMap is off"), std::string::npos) << output;
  for (const auto& entry : fs::directory_iterator(output_)) {
    EXPECT_NE(entry.path().extension(), ".tmp") << entry.path();
  }
}

TEST_F(ReliabilityTest, AFailedRerunLeavesTheEarlierSetWhole) {
  std::string output;
  ASSERT_EQ(Build("", &output), 0) << output;
  const std::string report = ReadText(output_ + "/report.json");
  const std::string cloud = ReadText(output_ + "/map.ply");
  fs::resize_file(Listed("depth.txt").back(), 60);
  EXPECT_EQ(Build("", &output), 2) << output;
  EXPECT_EQ(ReadText(output_ + "/report.json"), report);
  EXPECT_EQ(ReadText(output_ + "/map.ply"), cloud);
}

// Outputs in the sequence folder would be replaced wholesale by the next run and read as part of
// the sequence: the folder itself and any folder inside it are refused, with nothing written.
TEST_F(ReliabilityTest, AnOutputFolderInsideTheSequenceIsRefused) {
  for (const std::string& inside : {sequence_, sequence_ + "/", sequence_ + "/out",
                                    sequence_ + "/rgb/../maps/run1", dir_ / "seq/./x"}) {
    std::string output;
    EXPECT_EQ(RunStillmap("build " + sequence_ + " -o " + inside + " --poses groundtruth --quiet",
                          &output),
              2)
        << inside;
    EXPECT_NE(output.find("sequence folder"), std::string::npos) << inside << ": " << output;
  }
  std::string output;
  EXPECT_EQ(
      RunStillmap("build " + sequence_ + "/ -o " + sequence_ + "/out --poses groundtruth", &output),
      2)
      << "a sequence named with a trailing '/': " << output;
  EXPECT_FALSE(fs::exists(sequence_ + "/out"));
  EXPECT_FALSE(fs::exists(sequence_ + "/maps"));
  EXPECT_FALSE(fs::exists(sequence_ + "/report.json"));
  // A sibling whose name starts like the sequence's is fine.
  EXPECT_EQ(
      RunStillmap("build " + sequence_ + " -o " + sequence_ + "_out --poses groundtruth --quiet",
                  &output),
      0)
      << output;
}

TEST_F(ReliabilityTest, AFolderInTheWayOfAnOutputIsRefusedBeforeAnyWork) {
  fs::create_directories(output_ + "/report.json");
  std::string output;
  EXPECT_EQ(Build("", &output), 2) << output;
  EXPECT_NE(output.find("report.json: a folder is in the way"), std::string::npos) << output;
  EXPECT_FALSE(fs::exists(output_ + "/map.ply"));
}

TEST_F(ReliabilityTest, ASecondBuildIntoALockedFolderIsRefused) {
  fs::create_directories(output_);
  const int lock = ::open((output_ + "/.stillmap.lock").c_str(), O_RDWR | O_CREAT, 0644);
  ASSERT_GE(lock, 0);
  ASSERT_EQ(::flock(lock, LOCK_EX | LOCK_NB), 0);  // as a running build holds it
  std::string output;
  EXPECT_EQ(Build("", &output), 2) << output;
  EXPECT_NE(output.find("another stillmap run is writing into this folder"), std::string::npos)
      << output;
  EXPECT_FALSE(fs::exists(output_ + "/map.ply"));
  ::close(lock);
  EXPECT_EQ(Build("", &output), 0) << output;
}

TEST_F(ReliabilityTest, WhatAKilledRunLeftIsCleanedAndObjNamesItsMaterialFile) {
  fs::create_directories(output_ + "/.stillmap-staging");
  WriteText(output_ + "/.stillmap-staging/map.ply", "half written");
  WriteText(output_ + "/.map.ply.tmp", "an earlier version's temporary");
  std::string output;
  ASSERT_EQ(Build("--set mesh.format=obj", &output), 0) << output;
  EXPECT_FALSE(fs::exists(output_ + "/.stillmap-staging"));
  EXPECT_FALSE(fs::exists(output_ + "/.map.ply.tmp"));
  EXPECT_NE(ReadText(output_ + "/mesh.obj").find("mtllib mesh.mtl"), std::string::npos);
  EXPECT_TRUE(fs::exists(output_ + "/mesh.mtl"));
}

// ---- Empty results ------------------------------------------------------------------------------

TEST_F(ReliabilityTest, AnEmptyMapFailsClearlyWithNothingWritten) {
  for (const std::string& depth : Listed("depth.txt")) {
    cv::imwrite(depth, cv::Mat(48, 64, CV_16UC1, cv::Scalar(0)));
  }
  ExpectFailure(1, "the map is empty");
  for (const std::string& depth : Listed("depth.txt")) {
    cv::imwrite(depth, cv::Mat(48, 64, CV_16UC1, cv::Scalar(65535)));
  }
  ExpectFailure(1, "the map is empty");
}

TEST_F(ReliabilityTest, AnEmptyDepthRangeOrMeshFailsClearly) {
  ExpectFailure(1, "the map is empty", "--set mapping.min_depth=0.1 --set mapping.max_depth=0.11");
  ExpectFailure(1, "the mesh is empty", "--set mesh.min_points=100000000 --set mesh.format=obj");
}

// ---- Wild cameras and options -------------------------------------------------------------------

TEST_F(ReliabilityTest, ImpossibleCamerasAreRefused) {
  WriteCameraLine("distortion", "[1e10, -1e10, 0, 0, 1e10]");
  ExpectFailure(2, "distortion");
  WriteCameraLine("distortion", "[0, 0, 0, 0, 0]");
  WriteCameraLine("cx", "1e10");
  ExpectFailure(2, "principal point");
  WriteCameraLine("cx", "31.5");
  WriteCameraLine("fx", ".inf");
  ExpectFailure(2, "fx and fy");
  WriteCameraLine("fx", "1e300");
  WriteCameraLine("fy", "1e300");
  ExpectFailure(2, "field of view");
}

TEST_F(ReliabilityTest, IntegersThatWouldWrapAreRefused) {
  ExpectFailure(2, "tracking.max_features=4294968496", "--set tracking.max_features=4294968496");
  ExpectFailure(2, "mapping.pixel_stride=4294967297", "--set mapping.pixel_stride=4294967297");
  ExpectFailure(2, "sequence.max_frames=1e30", "--set sequence.max_frames=1e30");
}

TEST_F(ReliabilityTest, AGroundTruthFarFromItsOriginIsRefused) {
  std::string groundtruth;
  for (const char* line : {"1000.000000", "1000.033333", "1000.066667", "1000.100000"}) {
    groundtruth += std::string(line) + " 10000 0 0 0 0 0 1\n";
  }
  WriteText(sequence_ + "/groundtruth.txt", groundtruth);
  ExpectFailure(2, "the maps reach");
}

// ---- Files that are not what they should be -----------------------------------------------------

TEST_F(ReliabilityTest, FoldersFifosAndLinkLoopsWhereFilesBelong) {
  fs::remove(sequence_ + "/rgb.txt");
  fs::create_directory(sequence_ + "/rgb.txt");
  ExpectFailure(2, "rgb.txt: the file list (does the sequence have it?) is a folder");
  fs::remove(sequence_ + "/rgb.txt");
  ASSERT_EQ(::mkfifo((sequence_ + "/rgb.txt").c_str(), 0644), 0);
  ExpectFailure(2, "FIFO");  // refused, not blocked on
  fs::remove(sequence_ + "/rgb.txt");
  fs::create_symlink(sequence_ + "/rgb.txt", sequence_ + "/rgb.txt");
  ExpectFailure(2, "symbolic links");
}

TEST_F(ReliabilityTest, ACameraFileOrAnImageThatIsAFolder) {
  fs::remove(sequence_ + "/camera.yaml");
  fs::create_directory(sequence_ + "/camera.yaml");
  ExpectFailure(2, "camera.yaml: the camera file is a folder");
  fs::remove(sequence_ + "/camera.yaml");
  WriteCameraYaml(sequence_ + "/camera.yaml", testing::SmallCamera(), "");
  const std::string depth = Listed("depth.txt").front();
  fs::remove(depth);
  fs::create_directory(depth);
  ExpectFailure(2, "is a folder");
}

TEST_F(ReliabilityTest, ACorruptJpegThatStillEndsWellIsABadFrame) {
  const std::string color = Listed("rgb.txt").front();
  std::vector<unsigned char> jpeg;
  cv::imencode(".jpg", cv::imread(color), jpeg);
  for (size_t i = jpeg.size() / 2; i < jpeg.size() / 2 + 30; ++i) {
    jpeg[i] = static_cast<unsigned char>(i * 37);
  }
  WriteText(color, std::string(jpeg.begin(), jpeg.end()));  // still ends in FF D9
  ExpectFailure(2, "corrupt JPEG");
}

TEST_F(ReliabilityTest, EvalPlotNamesAndFarCoordinates) {
  std::string output;
  const std::string groundtruth = sequence_ + "/groundtruth.txt";
  EXPECT_EQ(
      RunStillmap("eval " + groundtruth + " " + groundtruth + " --plot " + dir_.path(), &output),
      2);
  EXPECT_NE(output.find("is a folder"), std::string::npos) << output;
  EXPECT_EQ(RunStillmap("eval " + groundtruth + " " + groundtruth + " --plot " + (dir_ / "plot"),
                        &output),
            2);
  EXPECT_NE(output.find(".png"), std::string::npos) << output;
  // Near 1e20 m, x + step == x: the plot's ticks must still end (ctest's time limit catches a
  // hang).
  std::string far;
  for (int i = 0; i < 4; ++i)
    far += std::to_string(1000 + i) + " 1e20 " + std::to_string(i) + " 0 0 0 0 1\n";
  WriteText(dir_ / "far.txt", far);
  EXPECT_EQ(RunStillmap("eval " + (dir_ / "far.txt") + " " + (dir_ / "far.txt") + " --plot " +
                            (dir_ / "far.png"),
                        &output),
            0)
      << output;
  EXPECT_TRUE(fs::exists(dir_ / "far.png"));
}

// info's advice for a folder without a camera is one info accepts, and following it works.
TEST_F(ReliabilityTest, InfoAdvisesAnOptionItTakes) {
  fs::remove(sequence_ + "/camera.yaml");
  std::string output;
  EXPECT_EQ(RunStillmap("info " + sequence_, &output), 2);
  EXPECT_NE(output.find("--camera-preset"), std::string::npos) << output;
  EXPECT_EQ(output.find("--set"), std::string::npos) << output;
  EXPECT_EQ(RunStillmap("info " + sequence_ + " --camera-preset ros_default", &output), 0)
      << output;
  EXPECT_NE(output.find("fx 525 fy 525"), std::string::npos) << output;  // the preset's
}

// The summary names what was written (read from the folder), the warnings, and report.html.
TEST_F(ReliabilityTest, TheSummaryListsTheFilesWarningsAndReport) {
  std::string output;
  ASSERT_EQ(RunStillmap("build " + sequence_ + " -o " + output_ +
                            " --poses groundtruth --detector none --set octomap.enabled=false",
                        &output),
            0)
      << output;
  EXPECT_NE(output.find("wrote map.ply, map.pcd, trajectory.txt"), std::string::npos) << output;
  const size_t wrote = output.find("wrote ");
  ASSERT_NE(wrote, std::string::npos) << output;
  const std::string wrote_line = output.substr(wrote, output.find('\n', wrote) - wrote);
  EXPECT_EQ(wrote_line.find("map.bt"), std::string::npos) << output;  // the OctoMap was off
  EXPECT_NE(output.find("renders/ ("), std::string::npos) << output;
  EXPECT_NE(output.find(output_ + "/report.html"), std::string::npos) << output;
  const std::string::size_type warnings = output.find(" warning(s) below");
  EXPECT_EQ(warnings == std::string::npos, output.find("warning:") == std::string::npos) << output;
}

// config.yaml holds what the command line decided (poses, detector, models, threads), and
// --config with it alone repeats the run: the same files, single-threaded so that they can be.
TEST_F(ReliabilityTest, ConfigYamlRepeatsTheRun) {
  std::string output;
  ASSERT_EQ(RunStillmap("build " + sequence_ + " -o " + output_ +
                            " --poses groundtruth --detector none --threads 1 --quiet "
                            "--set mapping.voxel_leaf_size=0.02",
                        &output),
            0)
      << output;
  const std::string config = ReadText(output_ + "/config.yaml");
  for (const std::string line : {"  poses: \"groundtruth\"", "  detector: \"none\"", "  threads: 1",
                                 "  voxel_leaf_size: 0.02"}) {
    EXPECT_NE(config.find(line), std::string::npos) << line << "\n" << config;
  }
  const std::string again = dir_ / "again";
  ASSERT_EQ(RunStillmap("build " + sequence_ + " -o " + again + " --config " + output_ +
                            "/config.yaml --quiet",
                        &output),
            0)
      << output;
  for (const std::string name : {"config.yaml", "trajectory.txt", "keyframes.txt", "map.ply"}) {
    EXPECT_EQ(ReadText(again + "/" + name), ReadText(output_ + "/" + name)) << name;
  }
  // The options themselves still win over the file.
  ASSERT_EQ(RunStillmap("build " + sequence_ + " -o " + again + " --config " + output_ +
                            "/config.yaml --threads 2 --quiet",
                        &output),
            0)
      << output;
  EXPECT_NE(ReadText(again + "/config.yaml").find("  threads: 2"), std::string::npos);
}

// The fixture is a wall with no floor: map.frame=groundtruth keeps the (true) warning that the
// floor frame fell back to the cameras' up out of these two tests.
TEST_F(ReliabilityTest, QuietMeansQuiet) {
  std::string output;
  ASSERT_EQ(Build("--detector none --set map.frame=groundtruth", &output), 0) << output;
  EXPECT_EQ(output, "");
}

// Without a floor (the fixture is a wall) the floor frame stands on the cameras' mean up, and the
// build says so, also under --quiet.
TEST_F(ReliabilityTest, WithoutAFloorTheMapFrameSaysItAssumedGravity) {
  std::string output;
  ASSERT_EQ(Build("--detector none", &output), 0) << output;
  EXPECT_NE(output.find("warning: no floor plane was found"), std::string::npos) << output;
  EXPECT_NE(ReadText(output_ + "/map.pcd").find("gravity assumed"), std::string::npos);
}

// The default detector (auto) without its model: the build runs on geometry alone and says so,
// once, even under --quiet.
TEST_F(ReliabilityTest, WithoutTheModelTheDefaultDetectorWarns) {
  fs::create_directories(dir_ / "no_models");
  std::string output;
  ASSERT_EQ(Build("--models " + (dir_ / "no_models") + " --set map.frame=groundtruth", &output), 0)
      << output;
  EXPECT_NE(output.find("warning: no detector model under"), std::string::npos) << output;
  EXPECT_EQ(output.find("warning", output.find("warning") + 1), std::string::npos) << output;
}

}  // namespace
}  // namespace stillmap
