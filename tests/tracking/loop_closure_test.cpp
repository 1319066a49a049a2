// The loop's pose graph against known truth: keyframes 1 m apart along a straight corridor, the
// tracked poses right up to keyframe 5 and all 0.5 m to the side from keyframe 6 on (one weak
// stretch of tracking, as a person walking ahead of the lens makes). The loop from keyframe 10
// back to keyframe 0 is measured at the truth. Where the frames between keyframes 5 and 6 were
// weak, the correction must go there; with every edge equally sure it is spread over the loop.
#include "stillmap/tracking/loop_closure.h"

#include <gtest/gtest.h>

#include <map>

namespace stillmap {
namespace {

constexpr int kKeyframes = 11;
constexpr int kJumpAt = 6;  // the first keyframe after the weak frames

Eigen::Isometry3d TruePose(int id) {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.translation() = Eigen::Vector3d(id, 0.0, 0.0);
  return pose;
}

// Each keyframe's error after the loop's correction [m], from the keyframes' weakest inliers.
std::map<int, double> CorrectedErrors(const std::map<int, int>& weakest_inliers) {
  std::map<int, Eigen::Isometry3d> tracked;
  for (int id = 0; id < kKeyframes; ++id) {
    tracked[id] = TruePose(id);
    if (id >= kJumpAt) tracked[id].translation().y() += 0.5;
  }
  const LoopClosure loops(LoopClosureOptions(), 1);
  LoopCorrection loop = loops.PrepareCorrection(tracked, weakest_inliers, {}, kKeyframes - 1, 0,
                                                TruePose(kKeyframes - 1));
  loops.Solve(&loop);
  EXPECT_FALSE(loop.error);
  std::map<int, double> errors;
  for (const auto& [id, correction] : LoopClosure::Corrections(loop)) {
    errors[id] = ((correction * tracked.at(id)).translation() - TruePose(id).translation()).norm();
  }
  return errors;
}

TEST(LoopClosureTest, TheCorrectionGoesWhereTrackingWasWeak) {
  std::map<int, int> weakest;
  for (int id = 0; id < kKeyframes; ++id) weakest[id] = 300;
  const std::map<int, double> even = CorrectedErrors(weakest);
  weakest[kJumpAt] = 0;  // a frame lost between keyframes 5 and 6
  const std::map<int, double> weighted = CorrectedErrors(weakest);
  ASSERT_EQ(weighted.size(), static_cast<size_t>(kKeyframes));
  for (const auto& [id, error] : weighted) EXPECT_LT(error, 0.01) << "keyframe " << id;
  EXPECT_GT(even.at(kJumpAt - 1), 0.1);  // spread evenly, the jump bends the whole corridor
  EXPECT_GT(even.at(kJumpAt), 0.1);
}

TEST(LoopClosureTest, OdometryWeightFollowsTheWeakestFrame) {
  LoopClosureOptions options;
  options.pose_graph_full_weight_inliers = 100;
  options.pose_graph_min_weight = 0.001;
  const LoopClosure loops(options, 1);
  EXPECT_DOUBLE_EQ(loops.OdometryWeight(100), 1.0);
  EXPECT_DOUBLE_EQ(loops.OdometryWeight(5000), 1.0);
  EXPECT_DOUBLE_EQ(loops.OdometryWeight(50), 0.25);
  EXPECT_DOUBLE_EQ(loops.OdometryWeight(1), 0.001);  // (1/100)^2 is below the least weight
  EXPECT_DOUBLE_EQ(loops.OdometryWeight(0), 0.001);
}

}  // namespace
}  // namespace stillmap
