// The tracker tests' fixture: 40 noise-free rendered frames of the static room (the rendering
// poses are the exact truth), shared by tracker_test.cpp and tracker_forget_test.cpp.
#pragma once

#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>
#include <utility>
#include <vector>

#include "rendered_sequence.h"
#include "stillmap/io/sequence.h"
#include "stillmap/tracking/tracker.h"
#include "test_util.h"

namespace stillmap {

// 40 noise-free frames of the static room, rendered once.
class TrackerTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new testing::TempDir;
    sequence_ = new Sequence(testing::RenderNoiseFreeSequence(*dir_ / "seq", "static", 40));
    for (size_t i = 0; i < sequence_->frames().size(); ++i) {
      frames_.push_back(sequence_->LoadFrame(i));
      cv::Mat gray;
      cv::cvtColor(frames_.back().color, gray, cv::COLOR_BGR2GRAY);
      grays_.push_back(gray);
    }
  }
  static void TearDownTestSuite() {
    frames_.clear();
    grays_.clear();
    delete sequence_;
    delete dir_;
  }
  // Inline bundle adjustment (deterministic), and a depth noise model for this depth, which is
  // exact up to the PNG's 0.2 mm steps: the default (0.0025 1/m, a Kinect) lets the jitter of
  // ORB corners between rendered views (about 1 px at the upper pyramid levels) trade lateral
  // translation for rotation, giving 4 mm mean frame-to-frame errors here instead of 0.5 mm.
  // The depth self-calibration is off: with depth declared this exact, the joint estimate's test
  // (p' I p, which scales with 1 / sigma^2) takes the corner jitter for a sensor error. Its gate
  // is tested in bundle_adjustment_test.cpp with a realistic noise model.
  static TrackerOptions Deterministic() {
    TrackerOptions options;
    options.local_map.background_bundle_adjustment = false;
    options.matching.sigma_inverse_depth = 0.0001;
    options.matching.depth_self_calibration = false;
    return options;
  }
  // The first `count` frames, the lens covered (black image, no depth) in frames 10-12.
  static std::vector<TrackResult> TrackWithCoveredLens(Tracker* tracker, size_t count) {
    const cv::Mat black(grays_[0].size(), CV_8UC1, cv::Scalar(0));
    const cv::Mat no_depth(grays_[0].size(), CV_32FC1, cv::Scalar(0));
    std::vector<TrackResult> results;
    for (size_t i = 0; i < count; ++i) {
      const bool covered = i >= 10 && i < 13;
      results.push_back(tracker->Track(i, frames_[i].time, covered ? black : grays_[i],
                                       covered ? no_depth : frames_[i].depth_m));
    }
    return results;
  }
  // Frames 0..count-1, each tracked.
  static void TrackFirstFrames(Tracker* tracker, size_t count) {
    for (size_t i = 0; i < count; ++i) {
      ASSERT_TRUE(tracker->Track(i, frames_[i].time, grays_[i], frames_[i].depth_m).tracked());
    }
  }
  // Frame i mirrored: plenty of corners with depth, none that the map recognizes (ORB
  // descriptors are not mirror-invariant). Gray image, then depth.
  static std::pair<cv::Mat, cv::Mat> MirroredView(size_t i) {
    std::pair<cv::Mat, cv::Mat> view;
    cv::flip(grays_[i], view.first, 1);
    cv::flip(frames_[i].depth_m, view.second, 1);
    return view;
  }
  static std::vector<TrackStatus> Statuses(const std::vector<TrackResult>& results) {
    std::vector<TrackStatus> statuses;
    statuses.reserve(results.size());
    for (const TrackResult& result : results) statuses.push_back(result.status);
    return statuses;
  }
  // The same frames, each pose the same to the last bits (1e-12).
  static void ExpectSamePoses(const Trajectory& a, const Trajectory& b) {
    ASSERT_EQ(a.size(), b.size());
    for (size_t i = 0; i < a.size(); ++i) {
      EXPECT_TRUE(a.poses()[i].world_from_camera.isApprox(b.poses()[i].world_from_camera, 1e-12))
          << i;
    }
  }
  static const Eigen::Isometry3d& Truth(size_t i) {
    return sequence_->groundtruth()->poses()[i].world_from_camera;
  }

  inline static testing::TempDir* dir_ = nullptr;
  inline static Sequence* sequence_ = nullptr;
  inline static std::vector<Frame> frames_;
  inline static std::vector<cv::Mat> grays_;
};

}  // namespace stillmap
