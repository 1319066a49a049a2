// The map re-check on an analytic scene: a wall at 3 m, a box 1.5 m in front of it where other
// keyframes saw the wall.
#include "stillmap/tracking/map_recheck.h"

#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

#include "test_util.h"

namespace stillmap {
namespace {

const cv::Rect kBox(60, 40, 30, 40);

class MapRecheckTest : public ::testing::Test {
 protected:
  MapRecheckTest() : camera_(testing::SmallCamera(160, 120)), masker_(camera_, Options()) {}

  static DynamicMaskOptions Options() {
    DynamicMaskOptions options;
    options.min_region_px = 0;  // every region kept
    options.margin_px = 1;
    return options;
  }

  // The camera at the origin (every keyframe): the wall, with the box when asked.
  cv::Mat Depth(bool box) const {
    cv::Mat depth(camera_.height, camera_.width, CV_32FC1, cv::Scalar(3.0f));
    if (box) depth(kBox).setTo(1.5f);
    return depth;
  }

  MaskReference Keyframe(double time, bool box) const {
    MaskReference reference;
    reference.time = time;
    reference.depth_m = Depth(box);
    return reference;
  }

  // Pixels of `mask` inside and outside the box, and outside the box grown by `margin` pixels.
  struct Split {
    int inside = 0, outside = 0, beyond_margin = 0;
  };
  static Split SplitByBox(const cv::Mat& mask, int margin) {
    Split split;
    const cv::Rect grown(kBox.x - margin, kBox.y - margin, kBox.width + 2 * margin,
                         kBox.height + 2 * margin);
    for (int v = 0; v < mask.rows; ++v) {
      for (int u = 0; u < mask.cols; ++u) {
        if (mask.at<std::uint8_t>(v, u) == 0) continue;
        const cv::Point p(u, v);
        if (kBox.contains(p)) {
          ++split.inside;
        } else {
          ++split.outside;
          if (!grown.contains(p)) ++split.beyond_margin;
        }
      }
    }
    return split;
  }

  Camera camera_;
  GeometricMasker masker_;
};

// The first keyframe has no earlier reference: the online check could not judge the box. Later
// keyframes saw the wall there, so the re-check finds it, grown by margin_px, and keeps what the
// mask held already.
TEST_F(MapRecheckTest, TheFirstKeyframeIsJudgedAgainstLaterOnes) {
  const MapRecheck recheck(masker_, Options());
  MaskReference later_1 = Keyframe(1.0, false), later_2 = Keyframe(2.0, false);
  cv::Mat detector_mask(camera_.height, camera_.width, CV_8UC1, cv::Scalar(0));
  detector_mask(cv::Rect(0, 0, 5, 5)).setTo(255);
  bool changed = false;
  const cv::Mat mask = recheck.Recheck(0.0, Depth(true), Eigen::Isometry3d::Identity(),
                                       detector_mask, {&later_1, &later_2}, &changed);
  EXPECT_TRUE(changed);
  const Split split = SplitByBox(mask, 1);
  EXPECT_EQ(split.inside, kBox.area());
  EXPECT_GT(split.outside, 25);        // the margin ...
  EXPECT_EQ(split.beyond_margin, 25);  // ... and the detector's 5 x 5 pixels only
  EXPECT_EQ(cv::countNonZero(mask(cv::Rect(0, 0, 5, 5))), 25);
  EXPECT_FALSE(later_2.nearest_depth_m.empty());  // cached for the next keyframes
}

TEST_F(MapRecheckTest, NothingIsAddedWithoutEvidence) {
  const MapRecheck recheck(masker_, Options());
  bool changed = true;
  // No reference at all: the box cannot be judged.
  cv::Mat mask =
      recheck.Recheck(0.0, Depth(true), Eigen::Isometry3d::Identity(), cv::Mat(), {}, &changed);
  EXPECT_FALSE(changed);
  EXPECT_TRUE(mask.empty());
  // A static keyframe against references that agree with it.
  MaskReference later = Keyframe(1.0, false);
  changed = true;
  mask = recheck.Recheck(0.0, Depth(false), Eigen::Isometry3d::Identity(), cv::Mat(), {&later},
                         &changed);
  EXPECT_FALSE(changed);
}

// Judged keyframes are remembered as earlier references; beyond the options' horizon
// (reference_spacing_s x reference_keyframes + 0.5 s) they are forgotten.
TEST_F(MapRecheckTest, RememberedKeyframesServeUntilTheHorizon) {
  MapRecheck recheck(masker_, Options());
  recheck.Remember(Keyframe(0.0, false), false);
  bool changed = false;
  const cv::Mat mask =
      recheck.Recheck(1.0, Depth(true), Eigen::Isometry3d::Identity(), cv::Mat(), {}, &changed);
  EXPECT_TRUE(changed);
  EXPECT_EQ(SplitByBox(mask, 1).inside, kBox.area());

  // The box stood still from t = 10 s: the wall seen at t = 0 is past the horizon and forgotten,
  // so the box now agrees with every reference.
  ASSERT_LT(Options().ReferenceHorizonS(), 10.0);
  recheck.Remember(Keyframe(10.0, true), false);
  recheck.Recheck(10.5, Depth(true), Eigen::Isometry3d::Identity(), cv::Mat(), {}, &changed);
  EXPECT_FALSE(changed);
}

}  // namespace
}  // namespace stillmap
