#include "keyframe_fuser.h"

#include <gtest/gtest.h>

#include "stillmap/io/sequence.h"
#include "test_util.h"

namespace stillmap {
namespace {

// Six keyframes of a plane 2 m ahead, 4 cm apart along x; the first three are fused where a
// drifting tracker put them (20 cm nearer), then a loop correction puts them right.
class KeyframeFuserTest : public ::testing::Test {
 protected:
  // Whole 16 px depth cells (RevisitCells): a part cell is never seen in full.
  KeyframeFuserTest() : camera_(testing::SmallCamera(96, 64)) {
    for (int i = 0; i < 6; ++i) {
      Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
      pose.translation() = Eigen::Vector3d(0.04 * i, 0.0, 0.0);
      poses_.push_back(pose);
    }
    testing::WritePlaneSequence(dir_.path(), camera_, testing::PlaneScene{}, poses_);
    drift_.translation() = Eigen::Vector3d(0.0, 0.0, 0.2);
  }

  // The poses after the correction, by keyframe id.
  std::map<int, Eigen::Isometry3d> Corrected() const {
    std::map<int, Eigen::Isometry3d> corrected;
    for (size_t i = 0; i < poses_.size(); ++i) corrected[static_cast<int>(i)] = poses_[i];
    return corrected;
  }

  // Holds and fuses keyframes [first, last), at the drifted poses when `drifted`.
  void Fuse(KeyframeFuser& fuser, size_t first, size_t last, bool drifted) {
    const Sequence sequence = Sequence::Open(dir_.path(), camera_);
    std::vector<FinalKeyframe> finals;
    for (size_t i = first; i < last; ++i) {
      FinalKeyframe keyframe;
      keyframe.id = static_cast<int>(i);
      keyframe.frame_index = i;
      keyframe.time = sequence.frames()[i].time;
      keyframe.world_from_camera = drifted ? drift_ * poses_[i] : poses_[i];
      keyframe.landmarks = {static_cast<int>(10 * i), static_cast<int>(10 * i + 1)};  // all new
      fuser.Hold(keyframe.id, sequence.LoadFrame(i), cv::Mat(), keyframe.world_from_camera);
      finals.push_back(std::move(keyframe));
    }
    fuser.Fuse(finals, DepthCorrection{});
  }

  // The back-projection's range, which the kept depth images are quantized over.
  static FuserOptions Options() {
    FuserOptions options;
    options.min_depth_m = 0.1;
    options.max_depth_m = 6.0;
    return options;
  }
  // A mapper fusing on the caller's thread (its memory() is read right after each step) and the
  // fuser that fills it.
  struct Fusing {
    Fusing(const Camera& camera, const MaskStage& masks)
        : mapper(camera, Synchronous()), fuser(camera, Options(), masks, &mapper) {}
    static MapperOptions Synchronous() {
      MapperOptions options;
      options.in_background = false;
      return options;
    }
    Mapper mapper;
    KeyframeFuser fuser;
  };

  // A fuser with keyframes.revisit_segment_max_seen_share `share`: the six keyframes fused, then
  // a new map segment begun.
  struct SegmentFusing {
    SegmentFusing(KeyframeFuserTest& test, double share)
        : mapper(test.camera_, Fusing::Synchronous()),
          fuser(test.camera_, WithShare(share), test.masks_, &mapper) {
      test.Fuse(fuser, 0, 6, false);
      fuser.NoteNewSegment();
    }
    static FuserOptions WithShare(double share) {
      FuserOptions options = Options();
      options.selection.revisit.segment_max_seen_share = share;
      return options;
    }
    Mapper mapper;
    KeyframeFuser fuser;
  };

  testing::TempDir dir_;
  Camera camera_;
  std::vector<Eigen::Isometry3d> poses_;
  Eigen::Isometry3d drift_ = Eigen::Isometry3d::Identity();
  MaskStage masks_{camera_, DynamicMaskOptions{}, false, nullptr, false, ""};
};

// A correction that moves fused keyframes empties the map and stops fusing into it; Refuse then
// gives exactly the map of a fuser that kept fusing throughout and fused everything again at the
// end: every point on the plane, none where the drifted poses put it.
TEST_F(KeyframeFuserTest, AMapEmptiedAtACorrectionIsTheSameOnceFusedAgain) {
  Fusing live(camera_, masks_);
  Fusing waiting(camera_, masks_);
  Fuse(live.fuser, 0, 3, true);
  Fuse(waiting.fuser, 0, 3, true);
  ASSERT_GT(waiting.mapper.memory().views, 0u);

  waiting.fuser.NoteCorrections(Corrected());
  EXPECT_TRUE(waiting.fuser.refusion_due());
  EXPECT_EQ(waiting.mapper.memory().views, 0u);  // emptied
  Fuse(live.fuser, 3, 6, false);
  Fuse(waiting.fuser, 3, 6, false);
  EXPECT_EQ(waiting.mapper.memory().views, 0u);  // nothing fused until Refuse
  EXPECT_GT(live.mapper.memory().views, 0u);

  EXPECT_EQ(live.fuser.Refuse(Corrected()), 3u);
  EXPECT_EQ(waiting.fuser.Refuse(Corrected()), 3u);
  EXPECT_FALSE(waiting.fuser.refusion_due());
  const FinishedMap a = live.mapper.Finish();
  const FinishedMap b = waiting.mapper.Finish();
  EXPECT_EQ(a.statistics.frames, 6u);
  EXPECT_EQ(b.statistics.frames, 6u);
  const std::vector<VoxelPoint> pa = a.cloud.Points(), pb = b.cloud.Points();
  ASSERT_GT(pa.size(), 100u);
  ASSERT_EQ(pa.size(), pb.size());
  for (size_t i = 0; i < pa.size(); ++i) {
    EXPECT_EQ(pa[i].position, pb[i].position);
    EXPECT_EQ(pa[i].rgb, pb[i].rgb);
    EXPECT_LT(std::abs(pb[i].position.z() - 2.0f), 1e-3f);
  }
  ASSERT_TRUE(a.occupancy && b.occupancy);
  EXPECT_EQ(a.occupancy->LeafCount(), b.occupancy->LeafCount());
  EXPECT_EQ(live.fuser.fused_poses().size(), waiting.fuser.fused_poses().size());
}

// Corrections that leave every fused keyframe where it was fused (within 1 mm and 0.05 degrees)
// change nothing: the map keeps being fused as the keyframes come.
TEST_F(KeyframeFuserTest, CorrectionsThatMoveNoFusedKeyframeKeepTheMapFusing) {
  Fusing one(camera_, masks_);
  KeyframeFuser& fuser = one.fuser;
  Mapper& mapper = one.mapper;
  Fuse(fuser, 0, 3, false);
  std::map<int, Eigen::Isometry3d> nudged = Corrected();
  for (auto& [id, pose] : nudged) pose.translation().x() += 0.0005;
  nudged[4].translation().x() += 0.5;  // not fused yet
  fuser.NoteCorrections(nudged);
  EXPECT_FALSE(fuser.refusion_due());
  const size_t views = mapper.memory().views;
  Fuse(fuser, 3, 6, false);
  EXPECT_GT(mapper.memory().views, views);
  EXPECT_EQ(fuser.Refuse(Corrected()), 0u);
  EXPECT_EQ(mapper.Finish().statistics.frames, 6u);
}

// After a new map segment begins, keyframes wait for Refuse; when nothing moved, Refuse fuses
// only those (the map fused before stays), giving the map of a fuser that fused all as they came
// (from the kept copies: depth within their 0.1 mm step, colour through the JPEG).
TEST_F(KeyframeFuserTest, KeyframesAfterANewSegmentWaitForRefuse) {
  Fusing live(camera_, masks_);
  Fusing waiting(camera_, masks_);
  Fuse(live.fuser, 0, 3, false);
  Fuse(waiting.fuser, 0, 3, false);
  waiting.fuser.NoteNewSegment();
  const size_t views = waiting.mapper.memory().views;
  ASSERT_GT(views, 0u);
  Fuse(live.fuser, 3, 6, false);
  Fuse(waiting.fuser, 3, 6, false);
  EXPECT_EQ(waiting.mapper.memory().views, views);  // the map fused before stays, nothing added
  EXPECT_EQ(waiting.fuser.Refuse(Corrected()), 0u);
  EXPECT_EQ(live.fuser.Refuse(Corrected()), 0u);
  const FinishedMap a = live.mapper.Finish();
  const FinishedMap b = waiting.mapper.Finish();
  EXPECT_EQ(b.statistics.frames, 6u);
  EXPECT_EQ(b.statistics.refusions, 0u);  // not emptied: only the waiting keyframes fused
  const std::vector<VoxelPoint> pa = a.cloud.Points(), pb = b.cloud.Points();
  ASSERT_GT(pa.size(), 100u);
  ASSERT_EQ(pa.size(), pb.size());
  for (size_t i = 0; i < pa.size(); ++i) {
    EXPECT_LT((pa[i].position - pb[i].position).norm(), 1e-4f);
    EXPECT_EQ(pa[i].count, pb[i].count);
  }
  EXPECT_EQ(live.fuser.fused_poses().size(), waiting.fuser.fused_poses().size());
}

// Keyframe `id` from frame `frame`'s images, said to be at `pose` (a revisit, in the time after
// the six).
FinalKeyframe Revisit(KeyframeFuser& fuser, const Sequence& sequence, int id, size_t frame,
                      const Eigen::Isometry3d& pose) {
  FinalKeyframe keyframe;
  keyframe.id = id;
  keyframe.frame_index = frame;
  keyframe.time = sequence.frames().back().time + id;
  keyframe.world_from_camera = pose;
  keyframe.landmarks = {1000 + id};  // new to the landmark rule
  Frame images = sequence.LoadFrame(frame);
  images.time = keyframe.time;
  fuser.Hold(id, std::move(images), cv::Mat(), pose);
  return keyframe;
}

// With keyframes.revisit_max_seen_share 0.9, a keyframe of a later visit that sees only what the
// six fused keyframes saw is not fused, whether it comes live or in a map segment joined later
// (nor is it kept for the session); one that sees 0.5 m of new plane is fused.
TEST_F(KeyframeFuserTest, ARevisitSeeingOnlyWhatWasFusedIsNotFused) {
  FuserOptions options = Options();
  options.selection.revisit.max_seen_share = 0.9;
  Mapper mapper(camera_, Fusing::Synchronous());
  KeyframeFuser fuser(camera_, options, masks_, &mapper);
  Fuse(fuser, 0, 6, false);
  const Sequence sequence = Sequence::Open(dir_.path(), camera_);
  fuser.Fuse({Revisit(fuser, sequence, 14, 2, poses_[2])}, DepthCorrection{});
  EXPECT_EQ(fuser.figures().seen_before, 1u);
  EXPECT_EQ(fuser.fused_poses().size(), 6u);
  Eigen::Isometry3d beside = poses_[5];
  beside.translation().x() += 0.5;
  fuser.Fuse({Revisit(fuser, sequence, 15, 5, beside)}, DepthCorrection{});
  EXPECT_EQ(fuser.figures().seen_before, 1u);
  EXPECT_EQ(fuser.fused_poses().size(), 7u);
  // Kept apart (its segment not joined), then joined where it saw only fused plane.
  fuser.Fuse({Revisit(fuser, sequence, 16, 3, Eigen::Isometry3d::Identity())}, DepthCorrection{},
             [](int id) { return id != 16; });
  EXPECT_EQ(fuser.FuseJoined([](int) { return true; }, {{16, poses_[3]}}), 0u);
  EXPECT_EQ(fuser.figures().seen_before, 2u);
  EXPECT_TRUE(fuser.TakeApart([](int) { return true; }).empty());
  EXPECT_EQ(fuser.Refuse(Corrected()), 0u);
  EXPECT_EQ(fuser.TakeSessionKeyframes().size(), 7u);
  EXPECT_EQ(mapper.Finish().statistics.frames, 7u);
}

// Off (1, the default), the same revisit is fused: its cells seen are left out, nothing more.
TEST_F(KeyframeFuserTest, WithTheSeenShareRuleOffARevisitIsFused) {
  Mapper mapper(camera_, Fusing::Synchronous());
  KeyframeFuser fuser(camera_, Options(), masks_, &mapper);
  Fuse(fuser, 0, 6, false);
  const Sequence sequence = Sequence::Open(dir_.path(), camera_);
  fuser.Fuse({Revisit(fuser, sequence, 14, 2, poses_[2])}, DepthCorrection{});
  EXPECT_EQ(fuser.figures().seen_before, 0u);
  EXPECT_EQ(fuser.fused_poses().size(), 7u);
  EXPECT_GT(fuser.figures().revisit_cells_left_out, 0u);
}

// With keyframes.revisit_segment_max_seen_share 0.9, a map segment whose keyframes see only what
// another segment's keyframes fused is not fused at the refusion, judged at the final poses
// whatever the keyframe ids (only their rays go into the map); the same keyframes in the first
// segment, or with the rule off (1, the default), are fused. A later refusion (everything 1 cm on)
// judges them again and counts them once.
TEST_F(KeyframeFuserTest, ASegmentSeeingOnlyWhatAnotherFusedIsNotFusedAtTheFinalPoses) {
  for (const auto& [later, share] : {std::pair{true, 0.9}, {false, 0.9}, {true, 1.0}}) {
    const bool later_segment = later;  // a lambda below takes it
    SCOPED_TRACE(::testing::Message() << "later segment " << later_segment << ", share " << share);
    SegmentFusing fusing(*this, share);
    KeyframeFuser& fuser = fusing.fuser;
    const Sequence sequence = Sequence::Open(dir_.path(), camera_);
    // Frames 1..3 again as keyframes 6..8, tracked 20 cm off (there they would see nothing
    // fused): the refusion judges them where the join put them, on frames 1..3's poses.
    std::vector<FinalKeyframe> finals;
    std::map<int, Eigen::Isometry3d> final_poses = Corrected();
    for (int k = 0; k < 3; ++k) {
      finals.push_back(Revisit(fuser, sequence, 6 + k, 1 + k, drift_ * poses_[1 + k]));
      final_poses[6 + k] = poses_[1 + k];
    }
    fuser.Fuse(finals, DepthCorrection{}, nullptr,
               [later_segment](int id) { return later_segment && id >= 6 ? 1 : 0; });
    EXPECT_EQ(fuser.Refuse(final_poses), 3u);  // the three the join moved
    for (auto& [id, pose] : final_poses) pose.translation().x() += 0.01;
    EXPECT_EQ(fuser.Refuse(final_poses), 9u);
    const bool dropped = later_segment && share < 1.0;
    const size_t fused = dropped ? 6u : 9u;
    EXPECT_EQ(fuser.figures().seen_before, dropped ? 3u : 0u);
    EXPECT_EQ(fuser.fused_poses().size(), fused);
    EXPECT_EQ(fuser.TakeSessionKeyframes().size(), fused);
    const FinishedMap map = fusing.mapper.Finish();
    EXPECT_EQ(map.statistics.frames, fused);
    EXPECT_EQ(map.statistics.rays_only_frames, 9u - fused);
    EXPECT_EQ(map.statistics.refusions, 2u);
  }
}

// At the refusion the segment rule only decides whether a keyframe is fused: one it keeps fuses
// the cells it was judged with when it came. Keyframe 14, a revisit of frame 2 tracked 20 cm off
// (where it saw nothing fused before), is put on frame 2's pose by the join: judged again there
// it would leave out every cell keyframe 2 saw; it fuses the same points with the rule as without.
TEST_F(KeyframeFuserTest, AKeyframeTheSegmentRuleKeepsFusesTheCellsItCameWith) {
  std::vector<size_t> points;
  for (const double share : {1.0, 0.9}) {
    SegmentFusing fusing(*this, share);
    KeyframeFuser& fuser = fusing.fuser;
    const Sequence sequence = Sequence::Open(dir_.path(), camera_);
    fuser.Fuse({Revisit(fuser, sequence, 14, 2, drift_ * poses_[2])}, DepthCorrection{});
    std::map<int, Eigen::Isometry3d> final_poses = Corrected();
    final_poses[14] = poses_[2];
    fuser.Refuse(final_poses);
    EXPECT_EQ(fuser.figures().seen_before, 0u);
    EXPECT_EQ(fuser.fused_poses().size(), 7u);
    points.push_back(fusing.mapper.Finish().statistics.points);
  }
  EXPECT_EQ(points[0], points[1]);
}

}  // namespace
}  // namespace stillmap
