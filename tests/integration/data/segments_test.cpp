// Map segments (issue 47) on real recordings: one recording of two different places (a shared
// sequence, then the other re-timed to follow it, one camera file). The map holds the first place
// only, as the first alone gives it; the second is written apart under segments/ as a build of its
// own, which `stillmap merge` joins with a build of that place.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <iostream>

#include "stillmap/pipeline/build_pipeline.h"
#include "stillmap/pipeline/merge_pipeline.h"
#include "test_util.h"

namespace stillmap {
namespace {

namespace fs = std::filesystem;

BuildResult Build(const std::string& sequence, const std::string& output,
                  const std::optional<std::string>& models) {
  BuildRequest request;
  request.sequence_dir = sequence;
  request.output_dir = output;
  request.config.run.detector = models ? "auto" : "none";
  request.config.run.models = models.value_or("");
  return RunBuild(request);
}

// `first` then `second`, re-timed, as one recording in `dir` (scripts/two_places.py).
std::string TwoPlaces(const std::string& first, const std::string& second, const std::string& dir) {
  const std::string command = std::string("python3 ") + STILLMAP_TWO_PLACES_SCRIPT + " " + first +
                              " " + second + " " + dir + " > /dev/null";
  EXPECT_EQ(std::system(command.c_str()), 0) << command;
  return dir;
}

// The build of `first` then `second` against `first` alone: the map holds the first place only,
// every segment after it is written apart with its poses and session record, and the summary
// says so. Returns the largest segment written apart (its folder).
std::string ExpectSecondPlaceApart(const std::string& first, const std::string& second,
                                   const testing::TempDir& dir, const std::string& name) {
  const std::optional<std::string> models = testing::SharedModels("yolox_nano");
  const BuildResult alone = Build(first, dir / (name + "_alone"), models);
  const std::string joined = TwoPlaces(first, second, dir / (name + "_seq"));
  const BuildResult both = Build(joined, dir / name, models);
  const double ratio = static_cast<double>(both.map.voxels) / static_cast<double>(alone.map.voxels);
  std::cout << name << ": voxels " << both.map.voxels << " against " << alone.map.voxels
            << " alone (" << ratio << "x), " << both.segments.size() << " segments\n";
  EXPECT_NEAR(ratio, 1.0, 0.05);
  EXPECT_GE(both.segments.size(), 2u);
  if (both.segments.size() < 2) return "";
  EXPECT_TRUE(both.segments[0].in_map);
  std::string largest;
  size_t largest_frames = 0;
  for (size_t k = 1; k < both.segments.size(); ++k) {
    const SegmentSummary& segment = both.segments[k];
    EXPECT_FALSE(segment.in_map) << "segment " << k << " of another place joined the map";
    const std::string folder = dir / name + "/segments/" + std::to_string(segment.id);
    EXPECT_TRUE(fs::exists(folder + "/trajectory.txt")) << folder;
    EXPECT_TRUE(fs::exists(folder + "/session.bin")) << folder;
    if (segment.frames > largest_frames) {
      largest_frames = segment.frames;
      largest = folder;
    }
  }
  size_t warnings = 0;
  for (const std::string& warning : both.warnings) {
    warnings += warning.find("written apart") != std::string::npos ? 1 : 0;
  }
  EXPECT_EQ(warnings, both.segments.size() - 1);
  EXPECT_TRUE(fs::exists(largest + "/map.ply")) << largest;
  return largest;
}

TEST(SegmentsTest, TheOfficeThenTeddysDeskKeepsTheDeskApartAndMergeJoinsIt) {
  const std::optional<std::string> bonn = testing::SharedSequence("bonn_crowd_a");
  const std::optional<std::string> teddy = testing::SharedSequence("tum_fr3_teddy_200");
  if (!bonn || !teddy) GTEST_SKIP() << "bonn_crowd_a or tum_fr3_teddy_200 not found";
  testing::TempDir dir;
  const std::string desk = ExpectSecondPlaceApart(*bonn, *teddy, dir, "office_then_desk");
  ASSERT_FALSE(desk.empty());
  // The desk written apart is a session of its own: merge joins it with a build of the desk.
  const BuildResult desk_alone = Build(*teddy, dir / "desk", testing::SharedModels("yolox_nano"));
  MergeRequest request;
  request.session_dirs = {dir / "desk", desk};
  request.output_dir = dir / "merged";
  const MergeResult merged = RunMerge(request);
  ASSERT_EQ(merged.sessions.size(), 2u);
  EXPECT_TRUE(merged.sessions[1].joined) << desk << " was not joined to the desk's build";
}

TEST(SegmentsTest, TeddysDeskThenTheOfficeKeepsTheOfficeApart) {
  const std::optional<std::string> bonn = testing::SharedSequence("bonn_crowd_a");
  const std::optional<std::string> teddy = testing::SharedSequence("tum_fr3_teddy_200");
  if (!bonn || !teddy) GTEST_SKIP() << "bonn_crowd_a or tum_fr3_teddy_200 not found";
  testing::TempDir dir;
  ExpectSecondPlaceApart(*teddy, *bonn, dir, "desk_then_office");
}

}  // namespace
}  // namespace stillmap
