// Same recording, same options, same build: the same bytes. Builds of a short real clip (the first
// 90 frames of tum_fr3_teddy_200, tracked, default detector) through the binary, compared file by
// file: twice with the defaults, once of them while busy loops load both cores, and once with
// --threads 1 (no read-ahead, no background bundle adjustment or detector).
#include <gtest/gtest.h>

#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "test_util.h"

namespace stillmap {
namespace {

namespace fs = std::filesystem;
using testing::ReadText;
using testing::RunCommand;
using testing::TempDir;

// The outputs that must be equal to the byte for any --threads and any load.
std::vector<std::string> MapFiles(const std::string& out) {
  std::vector<std::string> names = {"trajectory.txt", "keyframes.txt", "map.ply",  "map.pcd",
                                    "map.bt",         "map.ot",        "grid.pgm", "grid.yaml",
                                    "mesh.glb",       "session.bin"};
  for (const fs::directory_entry& entry : fs::directory_iterator(out + "/renders")) {
    names.push_back("renders/" + entry.path().filename().string());
  }
  return names;
}

// report.json without the key that holds every timing, speed and memory figure.
nlohmann::json Figures(const std::string& out) {
  nlohmann::json report = nlohmann::json::parse(ReadText(out + "/report.json"));
  report.erase("timing");
  return report;
}

class RepeatabilityTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const std::optional<std::string> sequence = testing::SharedSequence("tum_fr3_teddy_200");
    if (!sequence) GTEST_SKIP() << "tum_fr3_teddy_200 not in ../shared/data";
    sequence_ = *sequence;
    // The default detector (Yolo-Fastest with YOLOX's second opinion, in the background) when
    // the models are here.
    const std::optional<std::string> models = testing::SharedModels("yolox_nano");
    if (models) models_ = " --models " + *models;
  }

  // Builds into WORK/out, run from WORK so that the command line (and so report.json) is the
  // same for every WORK.
  void Build(const std::string& work, const std::string& extra) const {
    fs::create_directories(work);
    std::string output;
    const int status =
        RunCommand("cd " + work + " && " + STILLMAP_BINARY + " build " + sequence_ +
                       " -o out --quiet --set sequence.max_frames=90" + models_ + extra,
                   &output);
    ASSERT_EQ(status, 0) << output;
  }

  static void ExpectSameMaps(const std::string& a, const std::string& b) {
    for (const std::string& name : MapFiles(a)) {
      ASSERT_TRUE(fs::exists(b + "/" + name)) << name;
      EXPECT_TRUE(ReadText(a + "/" + name) == ReadText(b + "/" + name)) << name << " differs";
    }
    EXPECT_EQ(MapFiles(a), MapFiles(b));
  }

  std::string sequence_;
  std::string models_;
  TempDir dir_;
};

// Two busy loops, one per core, for as long as it lives.
class BusyCores {
 public:
  explicit BusyCores(const std::string& pid_file) : pid_file_(pid_file) {
    std::string ignored;
    RunCommand("for i in 1 2; do (while :; do :; done) >/dev/null 2>&1 & echo $! >> " + pid_file_ +
                   "; done",
               &ignored);
  }
  ~BusyCores() {
    std::string ignored;
    RunCommand("kill $(cat " + pid_file_ + ")", &ignored);
  }
  BusyCores(const BusyCores&) = delete;
  BusyCores& operator=(const BusyCores&) = delete;

 private:
  std::string pid_file_;
};

TEST_F(RepeatabilityTest, TwoBuildsOneUnderLoadGiveTheSameBytes) {
  Build(dir_ / "a", "");
  {
    const BusyCores load(dir_ / "load.pids");
    Build(dir_ / "b", "");
  }
  ExpectSameMaps(dir_ / "a/out", dir_ / "b/out");
  EXPECT_EQ(ReadText(dir_ / "a/out/config.yaml"), ReadText(dir_ / "b/out/config.yaml"));
  EXPECT_EQ(Figures(dir_ / "a/out"), Figures(dir_ / "b/out"));
}

TEST_F(RepeatabilityTest, OneThreadGivesTheDefaultsBytes) {
  Build(dir_ / "a", "");
  Build(dir_ / "b", " --threads 1");
  ExpectSameMaps(dir_ / "a/out", dir_ / "b/out");
}

// The check can fail: a build with another option gives other bytes.
TEST_F(RepeatabilityTest, AnotherOptionGivesOtherBytes) {
  Build(dir_ / "a", "");
  Build(dir_ / "b", " --set tracking.bundle_adjustment_handover_frames=1");
  EXPECT_NE(ReadText(dir_ / "a/out/trajectory.txt"), ReadText(dir_ / "b/out/trajectory.txt"));
}

}  // namespace
}  // namespace stillmap
