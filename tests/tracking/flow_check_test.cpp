// The geometric check of paper 004 (KLT flow, epipolar distance, DBSCAN) against exact truth: a
// hand-made DBSCAN case, and the ground-truth masks of rendered walking people.
#include "stillmap/tracking/flow_check.h"

#include <gtest/gtest.h>

#include <array>
#include <iostream>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <random>
#include <string>

#include "rendered_sequence.h"
#include "stillmap/io/sequence.h"
#include "test_util.h"

namespace stillmap {
namespace {

TEST(DbscanTest, DenseBlobsAreClustersAndStragglersNoise) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> blob(-0.5f, 0.5f);
  std::vector<cv::Point2f> points;
  points.reserve(82);
  for (int i = 0; i < 60; ++i) points.emplace_back(blob(rng), blob(rng));           // cluster A
  for (int i = 0; i < 20; ++i) points.emplace_back(10 + blob(rng), 3 + blob(rng));  // cluster B
  points.emplace_back(5.0f, 5.0f);                                                  // noise
  points.emplace_back(-6.0f, 2.0f);                                                 // noise
  const std::vector<int> labels = Dbscan(points, 0.5, 4);
  for (int i = 1; i < 60; ++i) EXPECT_EQ(labels[static_cast<size_t>(i)], labels[0]);
  for (int i = 61; i < 80; ++i) EXPECT_EQ(labels[static_cast<size_t>(i)], labels[60]);
  EXPECT_GE(labels[0], 0);
  EXPECT_GE(labels[60], 0);
  EXPECT_NE(labels[0], labels[60]);
  EXPECT_EQ(labels[80], -1);
  EXPECT_EQ(labels[81], -1);
}

// Corners of rendered walking_xyz frames, checked against the people's masks, comparing each
// frame with the one 3 frames before (one frame apart, people and camera move about as far, and
// recall drops to 0.40). Measured with paper 004 as written (DBSCAN epsilon 0.5 px, 6 points, no
// epipolar floor): 2177 of
// 2718 points on people flagged (recall 0.80), 1012 of 14720 static points (6.9 %). Epsilon 1 px:
// recall 0.58, 4.6 %; 2 px: 0.40, 2.8 %. The check proposes candidates; the fusion of issue 5
// (detections, region growing) decides.
TEST(FlowCheckTest, FlagsPointsOnWalkingPeople) {
  testing::TempDir dir;
  const Sequence sequence = testing::RenderSequence(dir / "seq", "walking_xyz", 150);
  auto gray = [&](size_t i) {
    return cv::imread(sequence.frames()[i].color_path, cv::IMREAD_GRAYSCALE);
  };
  auto mask = [&](size_t i) { return testing::MovingObjectMask(dir / "seq", sequence, i); };
  const int gap = 3;
  // Paper 004 as written (every point outside the camera's cluster), and the default, which also
  // asks for 2 px off the epipolar line.
  FlowCheckOptions paper;
  paper.min_epipolar_distance_px = 0.0;
  const std::array<FlowCheckOptions, 2> variants = {paper, FlowCheckOptions()};
  struct Counts {
    size_t true_positive = 0, false_positive = 0, false_negative = 0, static_points = 0;
    double Recall() const {
      return true_positive / std::max(1.0, double(true_positive + false_negative));
    }
    double FalseAlarm() const { return false_positive / std::max(1.0, double(static_points)); }
  };
  std::array<Counts, 2> counts;
  for (size_t i = static_cast<size_t>(gap); i < sequence.frames().size(); i += 5) {
    const cv::Mat previous = gray(i - static_cast<size_t>(gap));
    const cv::Mat current = gray(i);
    std::vector<cv::Point2f> corners;
    cv::goodFeaturesToTrack(previous, corners, 800, 0.01, 7);
    const cv::Mat before = mask(i - static_cast<size_t>(gap));
    for (size_t v = 0; v < variants.size(); ++v) {
      const FlowCheckResult result = CheckFlow(previous, current, corners, variants[v]);
      ASSERT_TRUE(result.fundamental_found) << "frame " << i;
      for (size_t k = 0; k < corners.size(); ++k) {
        if (result.tracked[k] == 0) continue;
        const bool on_person = before.at<std::uint8_t>(cv::Point(corners[k])) != 0;
        const bool flagged = result.dynamic[k] != 0;
        counts[v].true_positive += on_person && flagged;
        counts[v].false_positive += !on_person && flagged;
        counts[v].false_negative += on_person && !flagged;
        counts[v].static_points += !on_person;
      }
    }
  }
  for (size_t v = 0; v < variants.size(); ++v) {
    std::cout << (v == 0 ? "paper 004" : "default (2 px off the epipolar line)") << ", gap " << gap
              << ": points on people flagged " << counts[v].true_positive << " of "
              << counts[v].true_positive + counts[v].false_negative << " (recall "
              << counts[v].Recall() << "); static points flagged " << counts[v].false_positive
              << " of " << counts[v].static_points << " (" << 100 * counts[v].FalseAlarm()
              << " %)\n";
  }
  EXPECT_GE(counts[0].Recall(), 0.75);
  EXPECT_LE(counts[0].FalseAlarm(), 0.10);
  // The floor drops static points (measured 6.9 -> 4.4 %) and about half the points on people
  // (0.80 -> 0.43); the region growing of the mask recovers them (whole-build recall 0.961 ->
  // 0.956 on walking_xyz).
  EXPECT_LT(counts[1].FalseAlarm(), 0.8 * counts[0].FalseAlarm());
  EXPECT_GE(counts[1].Recall(), 0.35);
}

// The pipeline runs the flow ahead on the decoding thread, frame after frame, into one reused gray
// buffer. FlowTracker must give each frame exactly what CheckFlow gives on that frame's own images
// with the previous frame's corners (its pyramids own their pixels, so overwriting the buffer does
// not change the kept previous pyramid), and its half-resolution corners must sit on corners.
TEST(FlowTrackerTest, StepsEqualTheCheckOnFreshImagesWithAReusedBuffer) {
  testing::TempDir dir;
  const Sequence sequence = testing::RenderSequence(dir / "seq", "walking_xyz", 12);
  auto gray = [&](size_t i) {
    return cv::imread(sequence.frames()[i].color_path, cv::IMREAD_GRAYSCALE);
  };
  FlowTracker tracker(400, FlowCheckOptions());
  cv::Mat buffer;
  size_t compared = 0;
  for (size_t i = 0; i < sequence.frames().size(); ++i) {
    gray(i).copyTo(buffer);  // same allocation every frame
    const FlowStep step = tracker.Next(buffer);
    if (i == 0) {
      EXPECT_TRUE(step.from.empty());
      continue;
    }
    const std::vector<cv::Point2f> corners = FlowCorners(gray(i - 1), 400, 8.0);
    ASSERT_EQ(step.from, corners) << "frame " << i;
    const FlowCheckResult fresh = CheckFlow(gray(i - 1), gray(i), corners);
    ASSERT_EQ(step.result.tracked, fresh.tracked) << "frame " << i;
    ASSERT_EQ(step.result.dynamic, fresh.dynamic) << "frame " << i;
    for (size_t k = 0; k < corners.size(); ++k) {
      ASSERT_EQ(step.result.current[k], fresh.current[k]) << "frame " << i << " point " << k;
    }
    ++compared;
  }
  EXPECT_EQ(compared, sequence.frames().size() - 1);

  // Half-resolution corners, mapped back, lie within a pixel of a full-resolution corner
  // response maximum: the minimum eigenvalue there is well above the image's median.
  const cv::Mat image = gray(5);
  cv::Mat response;
  cv::cornerMinEigenVal(image, response, 3);
  std::vector<float> all(response.begin<float>(), response.end<float>());
  std::nth_element(all.begin(), all.begin() + static_cast<long>(all.size() / 2), all.end());
  const float median = all[all.size() / 2];
  const std::vector<cv::Point2f> corners = FlowCorners(image, 400, 8.0);
  ASSERT_GE(corners.size(), 100u);
  size_t strong = 0;
  for (const cv::Point2f& corner : corners) {
    double best = 0.0;
    const cv::Rect around(cv::Point(corner) - cv::Point(1, 1), cv::Size(3, 3));
    cv::minMaxLoc(response(around & cv::Rect(cv::Point(), image.size())), nullptr, &best);
    strong += best > 10.0 * median ? 1 : 0;
  }
  EXPECT_GE(strong, corners.size() * 9 / 10);
}

}  // namespace
}  // namespace stillmap
