// Tracker::ForgetLandmarksFoundMoving against exact truth: rendered frames of a noise-free
// synthetic room, the first keyframe's left half taken as "found moving".
#include <gtest/gtest.h>

#include <algorithm>
#include <iostream>
#include <opencv2/imgproc.hpp>

#include "stillmap/io/sequence.h"
#include "stillmap/tracking/tracker.h"
#include "tracker_fixture.h"

namespace stillmap {
namespace {

// The static room's 40 noise-free frames (tracker_fixture.h).
class ForgetLandmarksTest : public TrackerTest {};

// The landmarks the first keyframe made in its left half, which a later keyframe "found moving",
// are forgotten: those nearer than close_depth (ORB-SLAM2's near points; far away the depth
// check's evidence is weak), at most as many as that half's keypoints with depth there, none again,
// none with the rule off (the default). The frames after track on the landmarks left.
TEST_F(ForgetLandmarksTest, LandmarksOnPixelsFoundMovingAreForgotten) {
  cv::Mat left(grays_[0].size(), CV_8UC1, cv::Scalar(0));
  left.colRange(0, left.cols / 2).setTo(255);
  auto forget_after_first_frame = [&](Tracker* tracker) {
    const TrackResult first = tracker->Track(0, frames_[0].time, grays_[0], frames_[0].depth_m);
    EXPECT_EQ(first.keyframe_id, 0);
    const size_t alive = tracker->statistics().landmarks;
    const size_t forgotten = tracker->ForgetLandmarksFoundMoving(first.keyframe_id, left);
    EXPECT_EQ(tracker->statistics().landmarks, alive - forgotten);
    EXPECT_EQ(tracker->statistics().landmarks_found_moving, forgotten);
    EXPECT_EQ(tracker->ForgetLandmarksFoundMoving(0, left), 0u);  // nothing left there
    return forgotten;
  };
  const FrameFeatures features = ExtractFeatures(grays_[0], frames_[0].depth_m, sequence_->camera(),
                                                 cv::Mat(), FeatureOptions{});
  auto left_keypoints_nearer = [&](double depth_m) {
    size_t count = 0;
    const int half = left.cols / 2;
    for (size_t i = 0; i < features.size(); ++i) {
      const double z = features.depth_m[i];
      const bool in_left = features.keypoints[i].pt.x < static_cast<float>(half) - 0.5f;
      count += z > 0.0 && z < depth_m && in_left ? 1 : 0;
    }
    return count;
  };

  Tracker kept(sequence_->camera(), Deterministic());  // off by default
  EXPECT_EQ(forget_after_first_frame(&kept), 0u);

  TrackerOptions near = Deterministic();
  near.local_map.forget_landmarks_found_moving = true;
  Tracker near_only(sequence_->camera(), near);
  const size_t forgotten_near = forget_after_first_frame(&near_only);
  const double close_m = near.local_map.close_depth;
  EXPECT_GT(forgotten_near, left_keypoints_nearer(close_m - 0.05) / 2);
  EXPECT_LE(forgotten_near, left_keypoints_nearer(close_m + 0.05));

  TrackerOptions every = near;
  every.local_map.close_depth = 100.0;
  Tracker tracker(sequence_->camera(), every);
  const size_t forgotten = forget_after_first_frame(&tracker);
  const size_t in_left = left_keypoints_nearer(100.0);
  std::cout << "forgotten " << forgotten_near << " nearer than " << close_m << " m, " << forgotten
            << " in all, of " << in_left << " left keypoints with depth\n";
  EXPECT_GT(forgotten, forgotten_near);
  EXPECT_GT(forgotten, in_left / 2);
  EXPECT_LE(forgotten, in_left);
  double worst_m = 0.0;
  for (size_t i = 1; i < 10; ++i) {
    const TrackResult result = tracker.Track(i, frames_[i].time, grays_[i], frames_[i].depth_m);
    ASSERT_TRUE(result.tracked()) << "frame " << i;
    const Eigen::Isometry3d error =
        (Truth(0).inverse() * Truth(i)).inverse() * result.world_from_camera;
    worst_m = std::max(worst_m, error.translation().norm());
  }
  // Measured: 3.4 mm at most (2.0 mm with the whole map, RelativePosesMatchTheRenderingPoses).
  std::cout << "relative to frame 0: at most " << worst_m * 1e3 << " mm\n";
  EXPECT_LT(worst_m, 0.005);
}

}  // namespace
}  // namespace stillmap
