// Map segments against rendered truth: keyframes of a synthetic room at their exact poses, the
// second segment's given in a frame of its own (an unknown offset from the first's). Agreeing links
// must join it back where it belongs; a place it never saw must never be joined.
#include "stillmap/tracking/map_segments.h"

#include <gtest/gtest.h>

#include <climits>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

#include "stillmap/io/sequence.h"
#include "stillmap/io/trajectory.h"
#include "stillmap/synth/synthetic.h"
#include "stillmap/tracking/features.h"
#include "test_util.h"

namespace stillmap {
namespace {

struct RenderedKeyframe {
  double time = 0.0;
  Eigen::Isometry3d world_from_camera;
  std::vector<SessionFeature> features;
};

// Every `step`-th frame of a noise-free rendered sequence (textures and colours from `seed`), with
// its true pose and its ORB features.
std::vector<RenderedKeyframe> Keyframes(const std::string& dir, const std::string& scenario,
                                        int frames, int step, std::uint64_t seed = 1) {
  SynthOptions options;
  options.scenario = scenario;
  options.frames = static_cast<size_t>(frames);
  options.seed = seed;
  options.depth_noise = options.color_noise = false;
  WriteSyntheticSequence(dir, options);
  const Sequence sequence = Sequence::Open(dir, ResolveCamera(dir, {}));
  const Trajectory truth = Trajectory::ReadTum(dir + "/groundtruth.txt");
  std::vector<RenderedKeyframe> out;
  for (size_t i = 0; i < sequence.frames().size(); i += static_cast<size_t>(step)) {
    const Frame frame = sequence.LoadFrame(i);
    cv::Mat gray;
    cv::cvtColor(frame.color, gray, cv::COLOR_BGR2GRAY);
    const FrameFeatures features =
        ExtractFeatures(gray, frame.depth_m, sequence.camera(), cv::Mat(), FeatureOptions());
    out.push_back({frame.time, truth.poses()[i].world_from_camera, SessionFeatures(features)});
  }
  return out;
}

class MapSegmentsTest : public ::testing::Test {
 protected:
  testing::TempDir dir_;
};

// The second half of the keyframes as a segment of its own, given 1.5 m and 40 degrees off the
// first's frame; returns the join's correction (nothing: never joined).
std::optional<SegmentCorrection> JoinSecondHalf(const std::vector<RenderedKeyframe>& keyframes,
                                                MapSegments* segments) {
  const size_t half = keyframes.size() / 2;
  Eigen::Isometry3d offset = Eigen::Isometry3d::Identity();
  offset.translate(Eigen::Vector3d(1.5, -0.4, 0.2));
  offset.rotate(Eigen::AngleAxisd(40.0 * M_PI / 180.0, Eigen::Vector3d::UnitZ()));
  std::optional<SegmentCorrection> correction;
  for (size_t k = 0; k < keyframes.size(); ++k) {
    const int id = static_cast<int>(k);
    if (k == 0 || k == half) segments->Begin(id, keyframes[k].time);
    const Eigen::Isometry3d pose =
        k < half ? keyframes[k].world_from_camera : offset * keyframes[k].world_from_camera;
    auto joined =
        segments->AddKeyframe(id, keyframes[k].time, pose, keyframes[k].features, INT_MAX);
    if (joined) {
      EXPECT_FALSE(correction) << "joined twice";
      correction = joined;
    }
  }
  return correction;
}

TEST_F(MapSegmentsTest, AgreeingLinksJoinASegmentWhereItBelongs) {
  // The hand-held sweep of an empty room: the second half sees what the first saw.
  const std::vector<RenderedKeyframe> keyframes = Keyframes(dir_ / "static", "static", 150, 5);
  MapSegments segments({});
  const std::optional<SegmentCorrection> correction = JoinSecondHalf(keyframes, &segments);
  ASSERT_TRUE(correction) << segments.figures().verified << " links verified";
  EXPECT_EQ(correction->segments, std::vector<int>{1});
  // Every keyframe of the second segment placed back at its true pose.
  for (const auto& [id, world_from_camera] : correction->world_from_keyframe) {
    const Eigen::Isometry3d& truth = keyframes[static_cast<size_t>(id)].world_from_camera;
    EXPECT_LT((world_from_camera.translation() - truth.translation()).norm(), 0.02) << id;
    EXPECT_LT(RotationAngleDeg(world_from_camera.inverse() * truth), 1.0) << id;
  }
  const std::vector<SegmentSummary> summaries = segments.Summaries();
  ASSERT_EQ(summaries.size(), 2u);
  EXPECT_EQ(summaries[0].join, SegmentJoin::kFirst);
  EXPECT_EQ(summaries[1].join, SegmentJoin::kLinked);
  EXPECT_GE(summaries[1].links, 3);
  EXPECT_TRUE(segments.InMap(1));
}

TEST_F(MapSegmentsTest, LinksBetweenCamerasFarApartAreNotUsed) {
  // The same sweep; its links span 0.1-1 m between the two cameras (by the truth). With a limit
  // below the shortest, every verified link is left out and the segment is never joined.
  const std::vector<RenderedKeyframe> keyframes = Keyframes(dir_ / "static", "static", 150, 5);
  MapSegmentOptions options;
  options.link_max_distance_m = 0.0;
  MapSegments segments(options);
  EXPECT_FALSE(JoinSecondHalf(keyframes, &segments));
  EXPECT_EQ(segments.figures().verified, 0u);
  EXPECT_GT(segments.figures().too_far, 0u);
  EXPECT_EQ(segments.Summaries()[1].join, SegmentJoin::kNotJoined);
  // The default limit keeps them (the test above: joined where it belongs).
  MapSegments kept({});
  EXPECT_TRUE(JoinSecondHalf(keyframes, &kept));
  EXPECT_EQ(kept.figures().too_far, 0u);
}

TEST_F(MapSegmentsTest, APlaceTheMapNeverSawIsNeverJoined) {
  // The same room, textured and coloured from another seed: another place.
  const std::vector<RenderedKeyframe> first = Keyframes(dir_ / "first", "static", 60, 5);
  const std::vector<RenderedKeyframe> second = Keyframes(dir_ / "second", "static", 60, 5, 7);
  MapSegments segments({});
  int id = 0;
  segments.Begin(id, first.front().time);
  for (const RenderedKeyframe& keyframe : first) {
    EXPECT_FALSE(segments.AddKeyframe(id++, keyframe.time, keyframe.world_from_camera,
                                      keyframe.features, INT_MAX));
  }
  segments.Begin(id, second.front().time + 10.0);
  for (const RenderedKeyframe& keyframe : second) {
    EXPECT_FALSE(segments.AddKeyframe(id++, keyframe.time + 10.0, keyframe.world_from_camera,
                                      keyframe.features, INT_MAX));
  }
  EXPECT_FALSE(segments.InMap(1));
  EXPECT_EQ(segments.Summaries()[1].join, SegmentJoin::kNotJoined);
  EXPECT_EQ(segments.Summaries()[1].keyframes, second.size());
  // After the last keyframe the place index is freed; the segments stay as they were.
  const size_t with_index = segments.MemoryBytes();
  segments.EndKeyframes();
  EXPECT_LT(segments.MemoryBytes(), with_index / 10);
  EXPECT_EQ(segments.Summaries()[1].keyframes, second.size());
  EXPECT_THROW(segments.AddKeyframe(id, second.back().time + 11.0, second.back().world_from_camera,
                                    second.back().features, INT_MAX),
               std::logic_error);
}

// The room's second half as its own segment, tracked with one bad step: from keyframe `kink` on,
// every pose 0.15 m off. Links to the first half join it and later ones close loops, after which
// the group settles: every `settle_after_loops` loops, and over the last ones after the last
// keyframe. Returns how far the first settle over the kink left each keyframe from the kink on
// from its true pose [m] (empty when none came); *after_last says whether that settle came after
// the last keyframe.
std::vector<double> SettledAfterABadStep(const std::vector<RenderedKeyframe>& keyframes,
                                         size_t kink, int weakest_at_kink,
                                         int settle_after_loops = 3, bool* after_last = nullptr) {
  const size_t half = keyframes.size() / 2;
  Eigen::Isometry3d step = Eigen::Isometry3d::Identity();
  step.translate(Eigen::Vector3d(0.15, 0.0, 0.0));
  MapSegmentOptions options;
  options.settle_after_loops = settle_after_loops;
  MapSegments segments(options);
  const auto errors_from_kink = [&](const std::map<int, Eigen::Isometry3d>& settled, size_t last) {
    std::vector<double> errors;
    for (size_t j = kink; j <= last; ++j) {
      errors.push_back((settled.at(static_cast<int>(j)).translation() -
                        keyframes[j].world_from_camera.translation())
                           .norm());
    }
    return errors;
  };
  for (size_t k = 0; k < keyframes.size(); ++k) {
    const int id = static_cast<int>(k);
    if (k == 0 || k == half) segments.Begin(id, keyframes[k].time);
    const Eigen::Isometry3d tracked =
        k < kink ? keyframes[k].world_from_camera : step * keyframes[k].world_from_camera;
    const auto correction =
        segments.AddKeyframe(id, keyframes[k].time, tracked, keyframes[k].features,
                             k == kink ? weakest_at_kink : INT_MAX);
    if (correction && correction->world_from_keyframe.count(static_cast<int>(kink)) > 0) {
      return errors_from_kink(correction->world_from_keyframe, k);
    }
  }
  if (after_last != nullptr) *after_last = true;
  const std::map<int, Eigen::Isometry3d> settled = segments.SettleLastLoops();
  EXPECT_TRUE(segments.SettleLastLoops().empty()) << "settled the same loops twice";
  if (settled.count(static_cast<int>(kink)) == 0) return {};
  return errors_from_kink(settled, keyframes.size() - 1);
}

TEST_F(MapSegmentsTest, ASettlePutsTheCorrectionWhereTrackingWasWeak) {
  const std::vector<RenderedKeyframe> keyframes = Keyframes(dir_ / "static", "static", 150, 5);
  const size_t kink = keyframes.size() * 3 / 4;
  // The frames before the kink's keyframe were lost (no inliers): its step weighs little, and
  // the settle takes the bad step out where it happened.
  const std::vector<double> weak = SettledAfterABadStep(keyframes, kink, 0);
  ASSERT_FALSE(weak.empty()) << "no settle over the kink";
  for (size_t j = 0; j < weak.size(); ++j) EXPECT_LT(weak[j], 0.01) << "keyframe " << kink + j;
  // The same step as sure as any other: the settle spreads it, the kink's keyframe stays off.
  const std::vector<double> sure = SettledAfterABadStep(keyframes, kink, INT_MAX);
  ASSERT_FALSE(sure.empty()) << "no settle over the kink";
  EXPECT_GT(sure.front(), 0.03);
}

TEST_F(MapSegmentsTest, TheLastLoopsSettleAfterTheLastKeyframe) {
  // Fewer loops come than a settle waits for: without the settle after the last keyframe, the
  // group would keep the bad step.
  const std::vector<RenderedKeyframe> keyframes = Keyframes(dir_ / "static", "static", 150, 5);
  const size_t kink = keyframes.size() * 3 / 4;
  bool after_last = false;
  const std::vector<double> errors = SettledAfterABadStep(keyframes, kink, 0, 1000, &after_last);
  ASSERT_FALSE(errors.empty()) << "no settle over the kink";
  EXPECT_TRUE(after_last) << "the join, not the last settle, moved the kink";
  for (size_t j = 0; j < errors.size(); ++j) EXPECT_LT(errors[j], 0.01) << "keyframe " << kink + j;
}

}  // namespace
}  // namespace stillmap
