// The merge's pose graph against exact truth: two sessions of one path, the second in a frame of
// its own, joined by links measured from the true poses; a third session without links.
#include "merge_graph.h"

#include <gtest/gtest.h>

#include "test_util.h"

namespace stillmap {
namespace {

Eigen::Isometry3d Pose(double yaw, const Eigen::Vector3d& position) {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitY()).toRotationMatrix();
  pose.translation() = position;
  return pose;
}

// A session whose keyframe k stands at map_from_world * world_from_camera[k], written to `path`
// (no images: the graph needs none) and opened as the merge opens it.
MergeSession WriteSession(const std::string& path, const Eigen::Isometry3d& map_from_world,
                          const std::vector<Eigen::Isometry3d>& world_from_camera, double time0) {
  SessionRecord record;
  record.camera = testing::SmallCamera();
  record.depth_unit_m = 0.001;
  record.map_frame.name = "floor";
  std::vector<SessionKeyframeBlocks> blocks(world_from_camera.size());
  for (size_t k = 0; k < blocks.size(); ++k) {
    blocks[k].keyframe.id = static_cast<int>(k);
    blocks[k].keyframe.time = time0 + static_cast<double>(k);
    blocks[k].keyframe.map_from_camera = map_from_world * world_from_camera[k];
  }
  WriteSessionRecord(path, record, blocks);
  MergeSession session;
  session.name = path;
  session.reader = std::make_unique<SessionRecordReader>(path);
  return session;
}

TEST(MergeGraphTest, LinksPlaceASessionAtItsTruePosesAndCorrectItsFrames) {
  testing::TempDir dir;
  std::vector<Eigen::Isometry3d> truth(8);
  for (int k = 0; k < 8; ++k) {
    truth[static_cast<size_t>(k)] = Pose(0.2 * k, Eigen::Vector3d(0.3 * k, 0.0, 0.05 * k));
  }
  const Eigen::Isometry3d b_from_world = Pose(0.5, Eigen::Vector3d(1.0, -0.2, 0.4));
  std::vector<MergeSession> sessions;
  sessions.push_back(WriteSession(dir / "a.bin", Eigen::Isometry3d::Identity(),
                                  {truth.begin(), truth.begin() + 5}, 0.0));
  sessions.push_back(
      WriteSession(dir / "b.bin", b_from_world, {truth.begin() + 3, truth.end()}, 3.0));
  sessions.push_back(WriteSession(dir / "c.bin", Pose(1.0, Eigen::Vector3d(5, 5, 5)),
                                  {truth.begin(), truth.begin() + 3}, 0.0));
  // Keyframes 3 and 4 of the path are in both sessions: a's 3, 4 are b's 0, 1.
  PairLinks ab;
  ab.session_a = 0;
  ab.session_b = 1;
  ab.agreeing = {{3, 0, Eigen::Isometry3d::Identity(), 100},
                 {4, 1, Eigen::Isometry3d::Identity(), 100}};
  ab.a_map_from_b_map = b_from_world.inverse() * Pose(0.02, Eigen::Vector3d(0.03, 0, 0));  // rough
  ab.joined = true;
  PairLinks ac;
  ac.session_a = 0;
  ac.session_b = 2;
  const JoinedSessions joined =
      JoinSessions(sessions, {ab, ac}, MergeOptions{}, PoseGraphOptions{});
  EXPECT_TRUE(joined.included[0] && joined.included[1]);
  EXPECT_FALSE(joined.included[2]);
  EXPECT_TRUE(joined.first_from_keyframe[2].empty());
  EXPECT_EQ(joined.links, 2u);
  ASSERT_EQ(joined.first_from_keyframe[1].size(), 5u);
  for (size_t k = 0; k < 5; ++k) {
    EXPECT_LT((joined.first_from_keyframe[0][k].matrix() - truth[k].matrix()).norm(), 1e-6) << k;
    EXPECT_LT((joined.first_from_keyframe[1][k].matrix() - truth[k + 3].matrix()).norm(), 1e-6)
        << k;
  }
  // A frame of b between its keyframes 1 and 2, in b's frame, moves into a's by the same
  // correction: b's frame in a's.
  const Eigen::Isometry3d in_b = b_from_world * Pose(0.9, Eigen::Vector3d(1.35, 0.1, 0.2));
  const Eigen::Isometry3d moved =
      CorrectedPose(sessions[1].record(), joined.first_from_keyframe[1], 4.5, in_b);
  EXPECT_LT((moved.matrix() - (b_from_world.inverse() * in_b).matrix()).norm(), 1e-6);
}

}  // namespace
}  // namespace stillmap
