// The tracker against exact truth: rendered frames of a noise-free synthetic room (the rendering
// poses).
#include "stillmap/tracking/tracker.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <iostream>
#include <opencv2/imgproc.hpp>
#include <tuple>
#include <utility>

#include "rendered_sequence.h"
#include "stillmap/io/evaluation.h"
#include "stillmap/io/sequence.h"
#include "test_util.h"
#include "tracker_fixture.h"

namespace stillmap {
namespace {

double AngleDeg(const Eigen::Matrix3d& rotation) {
  return Eigen::AngleAxisd(rotation).angle() * 180.0 / M_PI;
}

TEST_F(TrackerTest, RelativePosesMatchTheRenderingPoses) {
  Tracker tracker(sequence_->camera(), Deterministic());
  for (size_t i = 0; i < frames_.size(); ++i) {
    const TrackResult result = tracker.Track(i, frames_[i].time, grays_[i], frames_[i].depth_m);
    ASSERT_TRUE(result.tracked()) << "frame " << i;
    EXPECT_EQ(result.status, i == 0 ? TrackStatus::kInitialized : TrackStatus::kTracked);
  }
  tracker.Finish();
  const Trajectory trajectory = tracker.TrackedTrajectory();
  ASSERT_EQ(trajectory.size(), frames_.size());
  // World = the first camera: frame 0 is the identity.
  EXPECT_LT((trajectory.poses()[0].world_from_camera.matrix() - Eigen::Matrix4d::Identity()).norm(),
            1e-9);
  // Each frame's pose relative to the one before (the 1 mm / 0.1 deg), and relative to
  // the first frame, against the rendering poses. Measured: frame to frame 0.46 mm median,
  // 1.02 mm and 0.029 deg at most; relative to frame 0 at most 1.98 mm and 0.077 deg.
  std::vector<double> step_m;
  double worst_step_deg = 0.0, worst_m = 0.0, worst_deg = 0.0;
  for (size_t i = 1; i < frames_.size(); ++i) {
    const Eigen::Isometry3d truth_step = Truth(i - 1).inverse() * Truth(i);
    const Eigen::Isometry3d estimate_step = trajectory.poses()[i - 1].world_from_camera.inverse() *
                                            trajectory.poses()[i].world_from_camera;
    const Eigen::Isometry3d step_error = truth_step.inverse() * estimate_step;
    step_m.push_back(step_error.translation().norm());
    worst_step_deg = std::max(worst_step_deg, AngleDeg(step_error.linear()));
    const Eigen::Isometry3d error =
        (Truth(0).inverse() * Truth(i)).inverse() * trajectory.poses()[i].world_from_camera;
    worst_m = std::max(worst_m, error.translation().norm());
    worst_deg = std::max(worst_deg, AngleDeg(error.linear()));
  }
  std::sort(step_m.begin(), step_m.end());
  const double median_step_m = step_m[step_m.size() / 2];
  std::cout << "frame to frame: median " << median_step_m * 1e3 << " mm, largest "
            << step_m.back() * 1e3 << " mm, " << worst_step_deg
            << " deg; relative to frame 0: " << worst_m * 1e3 << " mm, " << worst_deg << " deg\n";
  EXPECT_LT(median_step_m, 0.001);
  EXPECT_LT(step_m.back(), 0.002);
  EXPECT_LT(worst_step_deg, 0.1);
  EXPECT_LT(worst_m, 0.0025);
  EXPECT_LT(worst_deg, 0.1);
  const TrackerStatistics stats = tracker.statistics();
  EXPECT_EQ(stats.tracked, frames_.size());
  EXPECT_EQ(stats.lost, 0u);
  EXPECT_GE(stats.keyframes, 2u);
  EXPECT_GE(stats.bundle_adjustments, 1u);
}

TEST_F(TrackerTest, EveryKeyframeBecomesFinalOnceInOrder) {
  TrackerOptions options = Deterministic();
  options.local_map.max_keyframe_interval = 5;  // several keyframes in 40 frames
  options.local_map.local_window = 3;           // and some leave the window before the end
  options.local_map.redundant_keyframe_share =
      1.0;  // the camera sways over one place: keep them all
  Tracker tracker(sequence_->camera(), options);
  std::vector<int> keyframes;
  std::vector<FinalKeyframe> finals;
  for (size_t i = 0; i < frames_.size(); ++i) {
    const TrackResult result = tracker.Track(i, frames_[i].time, grays_[i], frames_[i].depth_m);
    if (result.keyframe_id >= 0) keyframes.push_back(result.keyframe_id);
    for (const FinalKeyframe& keyframe : tracker.TakeFinalKeyframes()) finals.push_back(keyframe);
  }
  const size_t before_finish = finals.size();
  tracker.Finish();
  for (const FinalKeyframe& keyframe : tracker.TakeFinalKeyframes()) finals.push_back(keyframe);
  ASSERT_GE(keyframes.size(), 8u);
  EXPECT_GT(before_finish, 0u);                // final while tracking went on
  EXPECT_LT(before_finish, keyframes.size());  // the last window only at the end
  ASSERT_EQ(finals.size(), keyframes.size());
  for (size_t k = 0; k < finals.size(); ++k) {
    EXPECT_EQ(finals[k].id, keyframes[k]);
    // A final keyframe pose is the pose of its frame in the trajectory.
    const Eigen::Isometry3d truth = Truth(0).inverse() * Truth(finals[k].frame_index);
    EXPECT_LT((truth.translation() - finals[k].world_from_camera.translation()).norm(), 0.002);
  }
}

// A covered lens (no image, no depth) for three frames, with the motion model's ride-through off
// or cut to 2 frames: the frames it did not pose, and the guesses that ended lost (never
// confirmed), get no pose and count as lost; then relocalization.
TEST_F(TrackerTest, LostFramesGetNoPoseAndTrackingResumes) {
  for (const int ride : {0, 2}) {
    TrackerOptions options = Deterministic();
    options.relocalization.max_predicted_frames = ride;
    Tracker tracker(sequence_->camera(), options);
    const std::vector<TrackStatus> statuses = Statuses(TrackWithCoveredLens(&tracker, 20));
    const TrackStatus covered = ride == 0 ? TrackStatus::kLost : TrackStatus::kPredicted;
    EXPECT_EQ(statuses[10], covered) << ride;
    EXPECT_EQ(statuses[11], covered) << ride;
    EXPECT_EQ(statuses[12], TrackStatus::kLost) << ride;
    EXPECT_EQ(statuses[13], TrackStatus::kRelocalized) << ride;
    EXPECT_EQ(statuses[14], TrackStatus::kTracked) << ride;
    tracker.Finish();
    const Trajectory trajectory = tracker.TrackedTrajectory();
    ASSERT_EQ(trajectory.size(), 17u) << ride;
    for (const StampedPose& pose : trajectory.poses()) {
      EXPECT_TRUE(pose.time < frames_[10].time || pose.time > frames_[12].time) << ride;
    }
    const Eigen::Isometry3d truth = Truth(0).inverse() * Truth(19);
    EXPECT_LT(
        (trajectory.poses().back().world_from_camera.translation() - truth.translation()).norm(),
        0.002);
    const TrackerStatistics stats = tracker.statistics();
    EXPECT_EQ(stats.predicted, static_cast<size_t>(ride));
    EXPECT_EQ(stats.lost, 3u);
    EXPECT_EQ(stats.tracked, 17u);
    EXPECT_EQ(stats.relocalized, 1u);
    EXPECT_EQ(stats.new_maps, 0u);
  }
}

// The same covered lens with the defaults: the frames are posed by the constant-velocity model and
// flagged "predicted", make no keyframe, and tracking goes on without relocalizing.
TEST_F(TrackerTest, AnOccludedLensIsRiddenThroughByTheMotionModel) {
  Tracker tracker(sequence_->camera(), Deterministic());
  const std::vector<TrackResult> results = TrackWithCoveredLens(&tracker, 20);
  for (size_t i = 10; i < 13; ++i) {
    EXPECT_EQ(results[i].status, TrackStatus::kPredicted) << i;
    EXPECT_EQ(results[i].keyframe_id, -1) << i;
    EXPECT_EQ(results[i].static_depth_share, 0.0) << i;
  }
  EXPECT_EQ(results[13].status, TrackStatus::kTracked);
  tracker.Finish();
  const Trajectory trajectory = tracker.TrackedTrajectory();
  ASSERT_EQ(trajectory.size(), 20u);
  for (size_t i = 10; i < 14; ++i) {  // the camera moves slowly and evenly: the model holds
    const Eigen::Isometry3d truth = Truth(0).inverse() * Truth(i);
    EXPECT_LT((trajectory.poses()[i].world_from_camera.translation() - truth.translation()).norm(),
              0.003)
        << i;
  }
  const TrackerStatistics stats = tracker.statistics();
  EXPECT_EQ(stats.predicted, 3u);
  EXPECT_EQ(stats.lost, 0u);
  EXPECT_EQ(stats.relocalized, 0u);
}

// A featureless stretch: frames 10-14 show a uniform grey image over their true depth, so that
// ORB finds nothing. The dense RGB-D odometry poses them from the room's geometry alone, close to
// the rendering poses, and feature tracking resumes after. Without it (the default) they are
// lost.
TEST_F(TrackerTest, AFeaturelessStretchIsPosedByRgbdOdometry) {
  const cv::Mat grey(grays_[0].size(), CV_8UC1, cv::Scalar(128));
  auto track = [&](const TrackerOptions& options) {
    Tracker tracker(sequence_->camera(), options);
    std::vector<TrackResult> results;
    for (size_t i = 0; i < 20; ++i) {
      const bool blank = i >= 10 && i < 15;
      results.push_back(
          tracker.Track(i, frames_[i].time, blank ? grey : grays_[i], frames_[i].depth_m));
    }
    tracker.Finish();
    return std::make_pair(results, tracker.TrackedTrajectory());
  };
  TrackerOptions on = Deterministic();
  on.rgbd_odometry.enabled = true;
  const auto [results, trajectory] = track(on);
  for (size_t i = 10; i < 15; ++i) EXPECT_EQ(results[i].status, TrackStatus::kRgbdOdometry) << i;
  EXPECT_EQ(results[15].status, TrackStatus::kTracked);
  ASSERT_EQ(trajectory.size(), 20u);
  for (size_t i = 10; i < 20; ++i) {
    const Eigen::Isometry3d truth = Truth(0).inverse() * Truth(i);
    EXPECT_LT((trajectory.poses()[i].world_from_camera.translation() - truth.translation()).norm(),
              0.003)
        << i;
  }
  TrackerOptions off = Deterministic();
  off.relocalization.max_predicted_frames = 0;
  const auto [results_off, trajectory_off] = track(off);
  EXPECT_EQ(results_off[10].status, TrackStatus::kLost);
  EXPECT_LT(trajectory_off.size(), 20u);
}

// The check of weak feature poses by dense alignment. With every pose checked and no difference
// allowed, each tracked frame after the first takes the dense pose and the matches that fit it:
// each frame-to-frame motion, as tracked, is within 1 mm of the rendering poses' (a chain of
// dense alignments drifts: 5.5 mm by frame 19 here) and tracking goes on with those matches.
// With differences of a metre allowed, every frame is checked, none replaced, and the trajectory
// is the one without the check.
TEST_F(TrackerTest, WeakFeaturePosesAreCheckedByDenseAlignment) {
  // Every pose checked (0: none), a pose replaced when it differs by more than max_m or max_deg.
  auto track = [&](int below_inliers, double max_m, double max_deg) {
    TrackerOptions options = Deterministic();
    options.rgbd_odometry.check_below_inliers = below_inliers;
    options.rgbd_odometry.check_max_difference_m = max_m;
    options.rgbd_odometry.check_max_difference_deg = max_deg;
    Tracker tracker(sequence_->camera(), options);
    std::vector<TrackResult> results;
    for (size_t i = 0; i < 20; ++i) {
      results.push_back(tracker.Track(i, frames_[i].time, grays_[i], frames_[i].depth_m));
    }
    tracker.Finish();
    return std::make_tuple(results, tracker.TrackedTrajectory(), tracker.statistics());
  };
  const auto [results, trajectory, stats] = track(100000, 0.0, 0.0);
  EXPECT_EQ(stats.rgbd_checked, 19u);
  EXPECT_GE(stats.rgbd_replaced, 15u);
  EXPECT_EQ(stats.rgbd_replaced + stats.rgbd_refused, 19u);  // each one taken or refused
  ASSERT_EQ(trajectory.size(), 20u);
  for (size_t i = 1; i < 20; ++i) {
    EXPECT_EQ(results[i].status, TrackStatus::kTracked) << i;
    EXPECT_GE(results[i].inliers, 50) << i;
    const Eigen::Isometry3d truth = Truth(i - 1).inverse() * Truth(i);
    const Eigen::Isometry3d step =
        results[i - 1].world_from_camera.inverse() * results[i].world_from_camera;
    EXPECT_LT((step.translation() - truth.translation()).norm(), 0.001) << i;
  }
  const auto [loose_results, loose_trajectory, loose_stats] = track(100000, 1.0, 90.0);
  EXPECT_EQ(loose_stats.rgbd_checked, 19u);
  EXPECT_EQ(loose_stats.rgbd_replaced, 0u);
  const RgbdOdometryOptions defaults;
  const auto [off_results, off_trajectory, off_stats] =
      track(0, defaults.check_max_difference_m, defaults.check_max_difference_deg);
  EXPECT_EQ(off_stats.rgbd_checked, 0u);
  ExpectSamePoses(off_trajectory, loose_trajectory);
}

// With check_min_landmarks, a dense pose replaces a feature pose only when at least that many of
// the map's landmarks fit it. Every pose checked and any difference replacing it, as above: at 20
// the dense poses of the noise-free room, which 50 or more landmarks fit, are taken; with
// more landmarks asked than the frames hold, each is refused, and the feature pose and its matches
// stay as they were: the trajectory is the one without the check, to the last bit.
TEST_F(TrackerTest, ADensePoseTooFewLandmarksFitLeavesTheFeaturePose) {
  auto track = [&](int below_inliers, int min_landmarks) {
    TrackerOptions options = Deterministic();
    options.rgbd_odometry.check_below_inliers = below_inliers;
    options.rgbd_odometry.check_max_difference_m = 0.0;
    options.rgbd_odometry.check_max_difference_deg = 0.0;
    options.rgbd_odometry.check_min_landmarks = min_landmarks;
    Tracker tracker(sequence_->camera(), options);
    for (size_t i = 0; i < 20; ++i) {
      tracker.Track(i, frames_[i].time, grays_[i], frames_[i].depth_m);
    }
    tracker.Finish();
    return std::make_pair(tracker.TrackedTrajectory(), tracker.statistics());
  };
  const TrackerStatistics confirmed_stats = track(100000, 20).second;
  EXPECT_GE(confirmed_stats.rgbd_replaced, 15u);
  EXPECT_EQ(confirmed_stats.rgbd_unconfirmed, 0u);
  const auto [refused, refused_stats] = track(100000, 100000);
  EXPECT_EQ(refused_stats.rgbd_replaced, 0u);
  EXPECT_EQ(refused_stats.rgbd_unconfirmed, confirmed_stats.rgbd_replaced);
  const auto [unchecked, unchecked_stats] = track(0, 100000);
  EXPECT_EQ(unchecked_stats.rgbd_checked, 0u);
  ExpectSamePoses(refused, unchecked);
}

// A relocalization farther from the last good pose than the options allow is refused: with a
// bound of 0.01 mm and no speed allowance, the camera's few millimetres of motion during the
// covered frames are too much.
TEST_F(TrackerTest, ARelocalizationFarFromTheLastGoodPoseIsRefused) {
  TrackerOptions options = Deterministic();
  options.relocalization.max_predicted_frames = 0;
  options.relocalization.relocalization_max_distance_m = 1e-5;
  options.relocalization.relocalization_max_speed_mps = 0.0;
  Tracker tracker(sequence_->camera(), options);
  const std::vector<TrackStatus> statuses = Statuses(TrackWithCoveredLens(&tracker, 16));
  EXPECT_EQ(statuses[13], TrackStatus::kLost);
  EXPECT_GE(tracker.statistics().relocalizations_refused, 1u);
  EXPECT_EQ(tracker.statistics().relocalized, 0u);
}

// A relocalization is also judged against the motion model while the loss is short: the last
// good pose carried on by its velocity for the covered frames. With a bound of 0.01 mm the
// camera's sub-millimetre departure from constant velocity is too much; with a horizon shorter
// than the covered frames (four frames, 0.13 s) there is no such prediction and no such check.
TEST_F(TrackerTest, ARelocalizationFarFromTheMotionModelIsRefused) {
  auto track = [&](double horizon_s) {
    TrackerOptions options = Deterministic();
    options.relocalization.max_predicted_frames = 0;
    options.relocalization.motion_model_max_distance_m = 1e-5;
    options.relocalization.motion_model_horizon_s = horizon_s;
    Tracker tracker(sequence_->camera(), options);
    const std::vector<TrackStatus> statuses = Statuses(TrackWithCoveredLens(&tracker, 16));
    return std::make_pair(statuses[13], tracker.statistics());
  };
  const auto [status, stats] = track(0.5);
  EXPECT_EQ(status, TrackStatus::kLost);
  EXPECT_GE(stats.relocalizations_refused, 1u);
  EXPECT_EQ(stats.relocalized, 0u);
  const auto [short_status, short_stats] = track(0.05);
  EXPECT_EQ(short_status, TrackStatus::kRelocalized);
  EXPECT_EQ(short_stats.relocalizations_refused, 0u);
}

TEST_F(TrackerTest, AnUnrecognizableViewStartsANewMapAtTheLastGoodPose) {
  TrackerOptions options = Deterministic();
  options.relocalization.new_map_after_lost = 1;
  Tracker tracker(sequence_->camera(), options);
  TrackFirstFrames(&tracker, 5);
  const auto [mirrored_gray, mirrored_depth] = MirroredView(5);
  const TrackResult result = tracker.Track(5, frames_[5].time, mirrored_gray, mirrored_depth);
  EXPECT_EQ(result.status, TrackStatus::kNewMap);
  EXPECT_GE(result.keyframe_id, 0);
  tracker.Finish();
  const Trajectory trajectory = tracker.TrackedTrajectory();
  ASSERT_EQ(trajectory.size(), 6u);
  // Chained: the new map starts where the camera was last seen.
  EXPECT_LT((trajectory.poses()[5].world_from_camera.matrix() -
             trajectory.poses()[4].world_from_camera.matrix())
                .norm(),
            1e-9);
  EXPECT_EQ(tracker.statistics().new_maps, 1u);
}

// A view with few corners outside the moving mask (a blank wall beside a person) does not begin
// the new segment: the first view after it that has tracking.new_map_min_points does.
TEST_F(TrackerTest, ANewMapWaitsForAViewWithEnoughPoints) {
  TrackerOptions options = Deterministic();
  options.relocalization.new_map_after_lost = 1;
  options.relocalization.new_map_min_points = 300;
  Tracker tracker(sequence_->camera(), options);
  TrackFirstFrames(&tracker, 5);
  const auto [mirrored_gray, mirrored_depth] = MirroredView(5);
  cv::Mat mostly_masked(mirrored_gray.size(), CV_8U, cv::Scalar(255));
  mostly_masked(cv::Rect(0, 0, mirrored_gray.cols / 8, mirrored_gray.rows)).setTo(0);
  const TrackResult masked =
      tracker.Track(5, frames_[5].time, mirrored_gray, mirrored_depth, mostly_masked);
  ASSERT_LT(masked.features, 300);
  EXPECT_EQ(masked.status, TrackStatus::kLost);
  const TrackResult full = tracker.Track(6, frames_[6].time, mirrored_gray, mirrored_depth);
  ASSERT_GE(full.features, 300);
  EXPECT_EQ(full.status, TrackStatus::kNewMap);
  EXPECT_EQ(tracker.statistics().new_maps, 1u);
}

// Past tracking.new_map_after_lost lost frames the camera is not looked for in the map: the
// view after three covered frames, which relocalizes within a longer wait, begins a new map.
TEST_F(TrackerTest, PastTheWaitTheMapIsNotSearched) {
  auto status_after_cover = [&](int wait) {
    TrackerOptions options = Deterministic();
    options.relocalization.max_predicted_frames = 0;
    options.relocalization.new_map_after_lost = wait;
    Tracker tracker(sequence_->camera(), options);
    return Statuses(TrackWithCoveredLens(&tracker, 16))[13];
  };
  EXPECT_EQ(status_after_cover(4), TrackStatus::kRelocalized);
  EXPECT_EQ(status_after_cover(3), TrackStatus::kNewMap);
}

// The bundle adjustment on its own thread (the default): the same frames, tracked while the
// adjustment runs concurrently; results depend on timing, so the bounds are looser.
TEST_F(TrackerTest, BackgroundBundleAdjustmentKeepsTrackingAccurate) {
  TrackerOptions options = Deterministic();
  options.local_map.background_bundle_adjustment = true;
  options.local_map.max_keyframe_interval = 5;  // adjustments while frames keep coming
  Tracker tracker(sequence_->camera(), options);
  size_t finals = 0;
  for (size_t i = 0; i < frames_.size(); ++i) {
    ASSERT_TRUE(tracker.Track(i, frames_[i].time, grays_[i], frames_[i].depth_m).tracked());
    finals += tracker.TakeFinalKeyframes().size();
  }
  tracker.Finish();
  finals += tracker.TakeFinalKeyframes().size();
  const TrackerStatistics stats = tracker.statistics();
  EXPECT_EQ(finals, stats.keyframes);
  EXPECT_GE(stats.bundle_adjustments, 2u);
  const Trajectory trajectory = tracker.TrackedTrajectory();
  ASSERT_EQ(trajectory.size(), frames_.size());
  for (size_t i = 0; i < frames_.size(); ++i) {
    const Eigen::Isometry3d truth = Truth(0).inverse() * Truth(i);
    EXPECT_LT((truth.translation() - trajectory.poses()[i].world_from_camera.translation()).norm(),
              0.004)
        << "frame " << i;
  }
}

TEST_F(TrackerTest, IgnoredPixelsYieldNoFeatures) {
  // The mask of the next issue: the left half ignored, no keypoint may come from it.
  cv::Mat mask(grays_[0].size(), CV_8UC1, cv::Scalar(0));
  mask.colRange(0, mask.cols / 2).setTo(255);
  const FrameFeatures features =
      ExtractFeatures(grays_[0], frames_[0].depth_m, sequence_->camera(), mask, FeatureOptions{});
  ASSERT_GT(features.size(), 100u);
  for (const cv::KeyPoint& keypoint : features.keypoints) {
    EXPECT_GE(keypoint.pt.x, mask.cols / 2 - 1);
  }
}

TEST(TrackerOptionsTest, ImpossibleValuesAreNamed) {
  TrackerOptions options;
  options.local_map.local_window = 1;
  try {
    options.Validate();
    FAIL() << "accepted local_window = 1";
  } catch (const std::exception& e) {
    // On its own (no configuration registered its keys) the key is the field's own.
    EXPECT_NE(std::string(e.what()).find("local_window"), std::string::npos);
  }
}

}  // namespace
}  // namespace stillmap
