// Which frames and keyframes belong to the map's segments: a first map, then a loss whose new
// segment is never joined (nothing links it), then frames tracked on in it; and which segments
// apart are only frames lost again before they held a map.
#include "segment_keeper.h"

#include <gtest/gtest.h>

namespace stillmap {
namespace {

TrackResult Tracked(TrackStatus status, int keyframe_id = -1) {
  TrackResult result;
  result.status = status;
  result.keyframe_id = keyframe_id;
  return result;
}

TEST(SegmentKeeperTest, FramesAndKeyframesOfASegmentNeverJoinedAreNotInTheMap) {
  SegmentKeeper keeper{MapSegmentOptions{}};
  std::vector<StampedPose> poses;
  for (int i = 0; i < 20; ++i) {
    const double time = 100.0 + i;
    if (i == 0) {
      keeper.Frame(Tracked(TrackStatus::kInitialized, 0), time);
    } else if (i == 12) {
      keeper.Frame(Tracked(TrackStatus::kNewMap, 5), time);
    } else if (i == 10 || i == 11) {
      keeper.Frame(Tracked(TrackStatus::kLost), time);
      continue;  // lost: no pose
    } else {
      keeper.Frame(Tracked(TrackStatus::kTracked), time);
    }
    poses.push_back({time, Eigen::Isometry3d::Identity()});
  }
  const Trajectory trajectory(poses);
  const std::vector<bool> in_map = keeper.FramesInMap(trajectory);
  ASSERT_EQ(in_map.size(), 18u);
  for (size_t i = 0; i < in_map.size(); ++i) {
    EXPECT_EQ(in_map[i], trajectory.poses()[i].time < 110.0) << trajectory.poses()[i].time;
  }
  EXPECT_TRUE(keeper.KeyframeInMap(0));
  EXPECT_TRUE(keeper.KeyframeInMap(4));
  EXPECT_FALSE(keeper.KeyframeInMap(5));
  EXPECT_FALSE(keeper.KeyframeInMap(9));
}

// Segments apart with no keyframe kept for a map leave `apart` (their frames become lost frames);
// the others stay, in order, with their keyframes and poses.
TEST(SegmentKeeperTest, SegmentsLostAgainBeforeAKeyframeWasKeptLeaveTheSegmentsApart) {
  std::vector<ApartSegment> apart(3);
  for (int k = 0; k < 3; ++k) {
    apart[static_cast<size_t>(k)].summary.id = k + 1;
    apart[static_cast<size_t>(k)].trajectory =
        Trajectory({{10.0 * k, Eigen::Isometry3d::Identity()}});
  }
  SessionKeyframeBlocks blocks;
  blocks.keyframe.time = 20.0;
  apart[2].keyframes.Add(blocks);
  const std::vector<ApartSegment> lost = TakeLostAgain(&apart);
  ASSERT_EQ(lost.size(), 2u);
  EXPECT_EQ(lost[0].summary.id, 1);
  EXPECT_EQ(lost[1].summary.id, 2);
  EXPECT_EQ(lost[1].trajectory.size(), 1u);
  ASSERT_EQ(apart.size(), 1u);
  EXPECT_EQ(apart[0].summary.id, 3);
  ASSERT_EQ(apart[0].keyframes.size(), 1u);
  EXPECT_EQ(apart[0].keyframes.keyframe(0).time, 20.0);
}

}  // namespace
}  // namespace stillmap
