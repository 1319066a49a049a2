// Keypoints beside a masked person (features.h mask_clearance_px), on a constructed frame with
// exact depth: a torso the mask holds, an arm beside it the mask missed, at the torso's depth, and
// the background behind, all textured.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>

#include "stillmap/tracking/features.h"

namespace stillmap {
namespace {

constexpr float kBackgroundM = 3.0f, kPersonM = 1.5f;
const cv::Rect kTorso(260, 100, 140, 300);  // masked
const cv::Rect kArm(236, 120, 18, 220);     // not masked, 6 px left of the torso

struct ConstructedFrame {
  cv::Mat gray, depth_m, mask;
  Camera camera;
};

ConstructedFrame Construct() {
  ConstructedFrame frame;
  cv::Mat blocks(60, 80, CV_8UC1);
  cv::RNG rng(47);
  rng.fill(blocks, cv::RNG::UNIFORM, 0, 256);
  cv::resize(blocks, frame.gray, cv::Size(640, 480), 0, 0, cv::INTER_NEAREST);
  frame.depth_m = cv::Mat(480, 640, CV_32FC1, cv::Scalar(kBackgroundM));
  frame.depth_m(kTorso).setTo(kPersonM);
  frame.depth_m(kArm).setTo(kPersonM);
  frame.mask = cv::Mat::zeros(480, 640, CV_8UC1);
  frame.mask(kTorso).setTo(255);
  frame.camera.width = 640;
  frame.camera.height = 480;
  frame.camera.fx = frame.camera.fy = 525.0;
  frame.camera.cx = 319.5;
  frame.camera.cy = 239.5;
  return frame;
}

// How far a keypoint's centre lies outside a rectangle, along the farther axis [px] (0: inside).
double OutsideBy(const cv::KeyPoint& keypoint, const cv::Rect& rect) {
  const double dx = std::max({rect.x - static_cast<double>(keypoint.pt.x), 0.0,
                              keypoint.pt.x - (rect.x + rect.width - 1.0)});
  const double dy = std::max({rect.y - static_cast<double>(keypoint.pt.y), 0.0,
                              keypoint.pt.y - (rect.y + rect.height - 1.0)});
  return std::max(dx, dy);
}

bool Inside(const cv::KeyPoint& keypoint, const cv::Rect& rect) {
  return rect.contains(cv::Point(static_cast<int>(std::lround(keypoint.pt.x)),
                                 static_cast<int>(std::lround(keypoint.pt.y))));
}

struct Count {
  size_t arm_beside = 0;         // on the arm, their patch reaching the torso
  size_t background_beside = 0;  // on the background, their patch reaching the torso
  size_t in_torso = 0;
};

Count CountBeside(const FrameFeatures& features, const FeatureOptions& options) {
  Count count;
  for (const cv::KeyPoint& keypoint : features.keypoints) {
    const double patch =
        15.0 * std::pow(static_cast<double>(options.scale_factor), keypoint.octave);
    const bool beside = OutsideBy(keypoint, kTorso) < patch;
    if (Inside(keypoint, kTorso)) {
      ++count.in_torso;
    } else if (beside && Inside(keypoint, kArm)) {
      ++count.arm_beside;
    } else if (beside && OutsideBy(keypoint, kArm) > 2.0) {
      ++count.background_beside;
    }
  }
  return count;
}

TEST(MaskClearanceTest, TheArmBesideAMaskedTorsoGivesNoKeypointsTheBackgroundDoes) {
  const ConstructedFrame frame = Construct();
  FeatureOptions options;
  options.mask_clearance_px = 15.0;  // ORB's half patch
  options.max_features = 3000;

  FeatureOptions inside_only = options;
  inside_only.mask_clearance_px = 0.0;
  const Count before =
      CountBeside(ExtractFeatures(frame.gray, frame.depth_m, frame.camera, frame.mask, inside_only),
                  inside_only);
  EXPECT_EQ(before.in_torso, 0u);
  ASSERT_GT(before.arm_beside, 10u) << "the arm must have corners for the test to prove anything";

  const Count after = CountBeside(
      ExtractFeatures(frame.gray, frame.depth_m, frame.camera, frame.mask, options), options);
  EXPECT_EQ(after.in_torso, 0u);
  EXPECT_EQ(after.arm_beside, 0u);
  // The background behind the outline lies 1.5 m farther: it keeps its keypoints.
  EXPECT_GT(after.background_beside, 0.8 * before.background_beside);
  EXPECT_GT(before.background_beside, 10u);
}

TEST(MaskClearanceTest, ASmallMaskedRegionLeavesTheKeypointsBesideIt) {
  const ConstructedFrame frame = Construct();
  FeatureOptions options;
  options.mask_clearance_px = 15.0;
  options.max_features = 3000;
  options.mask_clearance_min_region_px = kTorso.area() + 1;
  const Count count = CountBeside(
      ExtractFeatures(frame.gray, frame.depth_m, frame.camera, frame.mask, options), options);
  EXPECT_EQ(count.in_torso, 0u);
  EXPECT_GT(count.arm_beside, 10u);
}

}  // namespace
}  // namespace stillmap
