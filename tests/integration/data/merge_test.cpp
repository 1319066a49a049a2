// Sessions merged into one map (issue 30): real sequences split into two overlapping sessions,
// each built on its own and merged, against the motion-capture trajectory and the whole
// sequence's build; a session of another place (a synthetic room) is never stacked in.
#include <gtest/gtest.h>

#include <filesystem>
#include <iostream>

#include "stillmap/io/error.h"
#include "stillmap/io/trajectory.h"
#include "stillmap/pipeline/build_pipeline.h"
#include "stillmap/pipeline/merge_pipeline.h"
#include "stillmap/synth/synthetic.h"
#include "test_util.h"

namespace stillmap {
namespace {

// The default build (the detector when its model is at hand) of frames first..first+count-1
// (count 0: to the end).
BuildResult Build(const std::string& sequence, const std::string& output, size_t first,
                  size_t count, const std::optional<std::string>& models) {
  BuildRequest request;
  request.sequence_dir = sequence;
  request.output_dir = output;
  request.config.run.detector = models ? "auto" : "none";
  request.config.run.models = models.value_or("");
  request.config.first_frame = first;
  request.config.max_frames = count;
  return RunBuild(request);
}

MergeResult Merge(const std::vector<std::string>& sessions, const std::string& output) {
  MergeRequest request;
  request.session_dirs = sessions;
  request.output_dir = output;
  return RunMerge(request);
}

void Print(const std::string& name, const MergeResult& merged, const BuildResult& whole) {
  std::cout << name << ": " << merged.graph_links << " links, voxels " << merged.map.voxels
            << " (whole build " << whole.map.voxels << ", "
            << static_cast<double>(merged.map.voxels) / static_cast<double>(whole.map.voxels)
            << "x), ATE all sessions " << (merged.ate_joint ? merged.ate_joint->rmse * 1e3 : -1.0)
            << " mm (whole build "
            << (whole.evaluation.ate ? whole.evaluation.ate->translation.rmse * 1e3 : -1.0)
            << " mm)\n";
}

// Splits `name` into two overlapping sessions, merges them and checks the figures: both
// joined, the trajectories under one alignment within `max_ate_m` of the truth, and no more than
// 1.05 times the voxels of the whole sequence's build (a place seen by both is not laid twice).
void ExpectSplitMerges(const std::string& name, size_t end_a, size_t first_b, double max_ate_m) {
  const std::optional<std::string> sequence = testing::SharedSequence(name);
  if (!sequence) GTEST_SKIP() << name << " not found (set STILLMAP_DATA or ../shared/data)";
  const std::optional<std::string> models = testing::SharedModels("yolox_nano");
  if (!models) GTEST_SKIP() << "yolox_nano not found (set STILLMAP_MODELS or ../shared/models)";
  testing::TempDir dir;
  const BuildResult whole = Build(*sequence, dir / "whole", 0, 0, models);
  Build(*sequence, dir / "a", 0, end_a + 1, models);
  Build(*sequence, dir / "b", first_b, 0, models);
  const MergeResult merged = Merge({dir / "a", dir / "b"}, dir / "merged");
  Print(name, merged, whole);
  ASSERT_EQ(merged.sessions.size(), 2u);
  EXPECT_TRUE(merged.sessions[0].joined && merged.sessions[1].joined);
  ASSERT_TRUE(merged.ate_joint.has_value());
  EXPECT_LE(merged.ate_joint->rmse, max_ate_m);
  EXPECT_LE(merged.map.voxels, 1.05 * static_cast<double>(whole.map.voxels));
  // The merged map is in the first session's frame: its first keyframe held where it was.
  const Trajectory own = Trajectory::ReadTum(dir / "a/trajectory.txt");
  const Trajectory moved = Trajectory::ReadTum(dir / "merged/trajectory_a.txt");
  ASSERT_EQ(own.size(), moved.size());
  EXPECT_LT((own.poses().front().world_from_camera.matrix() -
             moved.poses().front().world_from_camera.matrix())
                .norm(),
            1e-6);
  EXPECT_TRUE(testing::ReadText(dir / "merged/trajectory_b.txt").size() > 1000);
}

// The figures: teddy 0-119 and 80-192, ATE <= 8 mm; bonn_crowd_a 0-399 and 250-619,
// ATE <= 25 mm; both with at most 1.05 times the voxels of the whole build.
TEST(MergeTest, TeddySplitInTwoSessionsMergesIntoTheWholeMap) {
  ExpectSplitMerges("tum_fr3_teddy_200", 119, 80, 0.008);
}

TEST(MergeTest, BonnCrowdSplitInTwoSessionsMergesIntoTheWholeMap) {
  ExpectSplitMerges("bonn_crowd_a", 399, 250, 0.025);
}

// A session of another place (a synthetic room) beside two teddy sessions is left out with a
// warning naming it; with only one teddy session nothing can be joined (exit 2 on the command
// line).
TEST(MergeTest, ASessionOfAnotherPlaceIsNeverStacked) {
  const std::optional<std::string> sequence = testing::SharedSequence("tum_fr3_teddy_200");
  if (!sequence) GTEST_SKIP() << "tum_fr3_teddy_200 not found (set STILLMAP_DATA)";
  testing::TempDir dir;
  SynthOptions synth;
  synth.scenario = "static";
  synth.frames = 150;
  WriteSyntheticSequence(dir / "room_seq", synth);
  Build(dir / "room_seq", dir / "room", 0, 0, std::nullopt);
  Build(*sequence, dir / "teddy_a", 0, 120, std::nullopt);
  Build(*sequence, dir / "teddy_b", 80, 0, std::nullopt);
  const MergeResult merged = Merge({dir / "teddy_a", dir / "room", dir / "teddy_b"}, dir / "m");
  ASSERT_EQ(merged.sessions.size(), 3u);
  EXPECT_TRUE(merged.sessions[0].joined);
  EXPECT_FALSE(merged.sessions[1].joined);
  EXPECT_TRUE(merged.sessions[2].joined);
  for (const MergePairFigures& pair : merged.pairs) {
    if (pair.session_a == "room" || pair.session_b == "room") {
      EXPECT_FALSE(pair.joined);
    }
  }
  bool warned = false;
  for (const std::string& warning : merged.warnings) {
    warned = warned || warning.find("session 'room' shares no verified place") != std::string::npos;
  }
  EXPECT_TRUE(warned);
  EXPECT_FALSE(std::filesystem::exists(dir / "m/trajectory_room.txt"));
  try {
    Merge({dir / "teddy_a", dir / "room"}, dir / "m2");
    ADD_FAILURE() << "a teddy session and a synthetic room were merged";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("no session shares a verified place"), std::string::npos)
        << e.what();
  }
  EXPECT_FALSE(std::filesystem::exists(dir / "m2"));
}

}  // namespace
}  // namespace stillmap
