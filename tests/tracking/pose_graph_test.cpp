// The pose graph against known truth: a camera goes around a 4 m circle; odometry with a steady
// heading and scale drift leaves the end 0.5 m or more from the start; one loop edge (the truth's
// relative pose between the last and the first node) must pull every node back near the truth.
#include "stillmap/tracking/pose_graph.h"

#include <gtest/gtest.h>

#include <cmath>

namespace stillmap {
namespace {

constexpr int kNodes = 40;

Eigen::Isometry3d TruePose(int i) {
  const double angle = 2.0 * M_PI * i / kNodes;
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.translation() = Eigen::Vector3d(2.0 * std::cos(angle), 2.0 * std::sin(angle), 0.3);
  // Looking along the circle's tangent, z forward (camera convention).
  pose.linear() = Eigen::AngleAxisd(angle, Eigen::Vector3d::UnitZ()).toRotationMatrix() *
                  Eigen::AngleAxisd(-M_PI / 2, Eigen::Vector3d::UnitX()).toRotationMatrix();
  return pose;
}

// Odometry with drift: each step's rotation off by 0.6 degrees about the camera's y axis and its
// translation 2 % long.
Eigen::Isometry3d DriftedStep(int i) {
  Eigen::Isometry3d step = TruePose(i).inverse() * TruePose(i + 1);
  step.translation() *= 1.02;
  step.linear() =
      step.linear() *
      Eigen::AngleAxisd(0.6 * M_PI / 180.0, Eigen::Vector3d::UnitY()).toRotationMatrix();
  return step;
}

double RotationDeg(const Eigen::Matrix3d& rotation) {
  return Eigen::AngleAxisd(rotation).angle() * 180.0 / M_PI;
}

double PositionError(const std::vector<Eigen::Isometry3d>& poses) {
  double sum = 0.0;
  for (int i = 0; i < kNodes; ++i) {
    sum += (poses[static_cast<size_t>(i)].translation() - TruePose(i).translation()).squaredNorm();
  }
  return std::sqrt(sum / kNodes);
}

TEST(PoseGraphTest, ALoopEdgeTakesOutTheDrift) {
  PoseGraphProblem problem;
  problem.world_from_node.push_back(TruePose(0));
  for (int i = 0; i + 1 < kNodes; ++i) {
    problem.world_from_node.push_back(problem.world_from_node.back() * DriftedStep(i));
  }
  problem.fixed.assign(kNodes, false);
  problem.fixed[0] = true;
  for (int i = 0; i + 1 < kNodes; ++i) {
    problem.edges.push_back(EdgeBetween(i, i + 1, problem.world_from_node[static_cast<size_t>(i)],
                                        problem.world_from_node[static_cast<size_t>(i + 1)]));
  }
  const double drifted = PositionError(problem.world_from_node);
  const double gap =
      (problem.world_from_node.back().translation() - TruePose(kNodes - 1).translation()).norm();
  ASSERT_GT(gap, 0.5);
  // The loop: the last node seen from the first, as a verified place match would measure it.
  problem.edges.push_back({kNodes - 1, 0, TruePose(kNodes - 1).inverse() * TruePose(0), 1.0});

  const PoseGraphResult result = SolvePoseGraph(problem, PoseGraphOptions{});
  ASSERT_EQ(result.world_from_node.size(), static_cast<size_t>(kNodes));
  EXPECT_LT(result.final_cost, 0.05 * result.initial_cost);
  const double corrected = PositionError(result.world_from_node);
  EXPECT_LT(corrected, drifted / 5.0) << "drifted " << drifted << " m, corrected " << corrected;
  // The fixed node stays where it was, to the bit.
  EXPECT_TRUE(result.world_from_node[0].isApprox(problem.world_from_node[0], 1e-12));
  // The loop closes: the last node's pose relative to the first matches the measurement.
  const Eigen::Isometry3d closing =
      result.world_from_node.back().inverse() * result.world_from_node.front();
  const Eigen::Isometry3d measured = TruePose(kNodes - 1).inverse() * TruePose(0);
  EXPECT_LT((closing.translation() - measured.translation()).norm(), 0.05);
}

TEST(PoseGraphTest, WithoutALoopNothingMoves) {
  PoseGraphProblem problem;
  for (int i = 0; i < 5; ++i) problem.world_from_node.push_back(TruePose(i));
  problem.fixed = {true, false, false, false, false};
  for (int i = 0; i + 1 < 5; ++i) {
    problem.edges.push_back(EdgeBetween(i, i + 1, TruePose(i), TruePose(i + 1)));
  }
  const PoseGraphResult result = SolvePoseGraph(problem, PoseGraphOptions{});
  for (int i = 0; i < 5; ++i) {
    EXPECT_TRUE(result.world_from_node[static_cast<size_t>(i)].isApprox(TruePose(i), 1e-9));
  }
}

TEST(PoseGraphTest, RefusesMalformedGraphs) {
  PoseGraphProblem problem;
  problem.world_from_node = {TruePose(0), TruePose(1)};
  problem.fixed = {false, false};
  EXPECT_THROW(SolvePoseGraph(problem, PoseGraphOptions{}), std::invalid_argument);
  problem.fixed = {true, false};
  problem.edges.push_back({0, 2, Eigen::Isometry3d::Identity(), 1.0});
  EXPECT_THROW(SolvePoseGraph(problem, PoseGraphOptions{}), std::invalid_argument);
}

// Two edges disagree on one node's pose: the one whose information is in its translation sets
// the position, the other (its rotation's share a million times its weight) the rotation.
TEST(PoseGraphTest, AnEdgesRotationShareWeighsItsRotationAlone) {
  Eigen::Isometry3d near = Eigen::Isometry3d::Identity();
  near.translation() = Eigen::Vector3d(1.0, 0.0, 0.0);
  Eigen::Isometry3d turned = Eigen::Isometry3d::Identity();
  turned.translation() = Eigen::Vector3d(2.0, 0.0, 0.0);
  turned.linear() = Eigen::AngleAxisd(10.0 * M_PI / 180.0, Eigen::Vector3d::UnitZ()).matrix();
  PoseGraphProblem problem;
  problem.world_from_node = {Eigen::Isometry3d::Identity(), Eigen::Isometry3d::Identity()};
  problem.fixed = {true, false};
  PoseGraphEdge position{0, 1, near, 1.0};
  position.rotation_share = 1e-6;
  PoseGraphEdge rotation{0, 1, turned, 1e-6};
  rotation.rotation_share = 1e6;
  problem.edges = {position, rotation};
  const Eigen::Isometry3d solved = SolvePoseGraph(problem, PoseGraphOptions{}).world_from_node[1];
  EXPECT_LT((solved.translation() - near.translation()).norm(), 1e-3);
  EXPECT_LT(RotationDeg(solved.linear().transpose() * turned.linear()), 0.01);
}

}  // namespace
}  // namespace stillmap
