// A fleet's recordings on Slurm (issue 30): scripts/slurm/fleet.sh on a one-node cluster that the
// test starts on this machine (local_cluster.sh: munged, slurmctld and slurmd with private
// folders and ports, stopped at the end) builds four sessions of a synthetic room as a job array
// and merges them in a dependent job; the same builds and merge run locally give the same bytes.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "stillmap/synth/synthetic.h"
#include "test_util.h"

namespace stillmap {
namespace {

namespace fs = std::filesystem;

// A synthetic room (240 frames) in four overlapping sessions: the builds' options, by name.
const std::vector<std::pair<std::string, std::string>> kSessions = {
    {"s1", "--set sequence.max_frames=80"},
    {"s2", "--set sequence.first_frame=50 --set sequence.max_frames=80"},
    {"s3", "--set sequence.first_frame=110 --set sequence.max_frames=80"},
    {"s4", "--set sequence.first_frame=170"}};

class SlurmTest : public ::testing::Test {
 protected:
  void SetUp() override {
    std::string output;
    const int status = testing::RunCommand(
        std::string(STILLMAP_LOCAL_CLUSTER) + " start " + (dir_ / "cluster"), &output);
    if (status == 3) GTEST_SKIP() << output;  // slurm-wlm or munge not installed
    started_ = true;                          // stopped in TearDown whatever happened
    ASSERT_EQ(status, 0) << output << testing::ReadText(dir_ / "cluster/log/slurmd.log")
                         << testing::ReadText(dir_ / "cluster/log/slurmctld.log");
    slurm_conf_ = "SLURM_CONF=" + (dir_ / "cluster/slurm.conf");
    SynthOptions synth;
    synth.scenario = "static";
    synth.frames = 240;
    WriteSyntheticSequence(sequence_, synth);
  }
  void TearDown() override {
    std::string output;
    if (started_) {
      testing::RunCommand(std::string(STILLMAP_LOCAL_CLUSTER) + " stop " + (dir_ / "cluster"),
                          &output);
    }
  }

  testing::TempDir dir_;
  std::string sequence_ = dir_ / "room";
  bool started_ = false;
  std::string slurm_conf_;
};

TEST_F(SlurmTest, FleetRecipeGivesTheBytesOfLocalRuns) {
  const std::string detector = " --detector none";  // a room without people
  std::ofstream list(dir_ / "recordings.txt");
  list << "# a synthetic room in four overlapping sessions\n";
  for (const auto& [name, options] : kSessions) {
    list << name << " " << sequence_ << " " << options << detector << "\n";
  }
  list.close();
  std::string output;
  // The fleet: a job array of four builds, then the merge after them; --wait returns when the
  // merge has finished.
  ASSERT_EQ(testing::RunCommand(slurm_conf_ + " " + STILLMAP_FLEET + " " +
                                    (dir_ / "recordings.txt") + " " + (dir_ / "fleet") +
                                    " --wait --cpus 2 --stillmap " + STILLMAP_BINARY,
                                &output),
            0)
      << output << testing::ReadText(dir_ / "fleet/logs/merge.log");
  EXPECT_NE(output.find("job array"), std::string::npos) << output;
  // The same, locally.
  std::string merge = "merge";
  for (const auto& [name, options] : kSessions) {
    const std::string session = dir_ / ("local/" + name);
    std::string build = "build " + sequence_;
    build.append(" -o ").append(session).append(" ").append(options);
    build.append(" --threads 2 --quiet").append(detector);
    ASSERT_EQ(testing::RunStillmap(build, &output), 0) << output;
    merge += " " + session;
  }
  ASSERT_EQ(testing::RunStillmap(merge + " -o " + (dir_ / "local/merged") + " --threads 2 --quiet",
                                 &output),
            0)
      << output;
  for (const auto& [name, options] : kSessions) {
    for (const char* file : {"session.bin", "trajectory.txt", "keyframes.txt", "map.ply"}) {
      const std::string local = dir_ / ("local/" + name + "/" + file);
      const std::string fleet = dir_ / ("fleet/sessions/" + name + "/" + file);
      EXPECT_TRUE(testing::ReadText(local) == testing::ReadText(fleet)) << fleet << " differs";
    }
  }
  std::vector<std::string> merged = {"map.ply", "map.pcd",  "map.bt",
                                     "map.ot",  "grid.pgm", "grid.yaml"};
  for (const auto& [name, options] : kSessions) merged.push_back("trajectory_" + name + ".txt");
  for (const std::string& file : merged) {
    const std::string fleet = dir_ / ("fleet/merged/" + file);
    ASSERT_TRUE(fs::exists(fleet)) << fleet;
    EXPECT_TRUE(testing::ReadText(dir_ / ("local/merged/" + file)) == testing::ReadText(fleet))
        << fleet << " differs from the local merge";
  }
}

}  // namespace
}  // namespace stillmap
