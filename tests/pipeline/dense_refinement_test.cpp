// The final poses' dense refinement against a rendered room whose camera poses are exact: poses
// given a drift (short by 3 % and turning 0.2 degrees a keyframe, as feature tracking drifts
// along a corridor) must come back to the truth; where the alignments are refused the poses
// must stay as they were. In the floor's blank corridor, a keyframe far off must be found again.
#include "dense_refinement.h"

#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <string>

#include "stillmap/io/sequence.h"
#include "stillmap/io/truth_files.h"
#include "stillmap/synth/synthetic.h"
#include "test_util.h"

namespace stillmap {
namespace {

// A scenario's first `frames` frames rendered into a temporary folder, every `every`th of them a
// keyframe.
class Rendered {
 public:
  Rendered(const std::string& scenario, size_t frames, size_t every)
      : frames_(frames), every_(every) {
    SynthOptions options;
    options.scenario = scenario;
    options.frames = frames;
    WriteSyntheticSequence(dir_.path(), options);
    sequence_.emplace(Sequence::Open(dir_.path(), ResolveCamera(dir_.path(), {})));
  }

  const Camera& camera() const { return sequence_->camera(); }

  // The keyframes at their true poses.
  std::vector<RefinedKeyframe> Truth() const {
    std::vector<RefinedKeyframe> keyframes;
    for (size_t i = 0; i < frames_; i += every_) {
      const double time = sequence_->frames()[i].time;
      keyframes.push_back(
          {static_cast<int>(i), time, *sequence_->groundtruth()->Interpolate(time, 0.1)});
    }
    return keyframes;
  }

  // The keyframes' images; with `mask_moving`, no depth where the truth's masks say moving.
  KeyframeImages Images(bool mask_moving) const {
    return [this, mask_moving](size_t index, cv::Mat* gray, cv::Mat* depth_m) {
      const size_t i = index * every_;
      const Frame frame = sequence_->LoadFrame(i);
      cv::cvtColor(frame.color, *gray, cv::COLOR_BGR2GRAY);
      *depth_m = frame.depth_m.clone();
      if (mask_moving) {
        depth_m->setTo(0.0f, TruthMasks(dir_.path()).Get(sequence_->frames()[i].time));
      }
    };
  }

 private:
  testing::TempDir dir_;
  std::optional<Sequence> sequence_;
  size_t frames_, every_;
};

class DenseRefinementTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { room_ = new Rendered("static", 60, 6); }
  static void TearDownTestSuite() { delete room_; }

  static std::vector<RefinedKeyframe> Truth() { return room_->Truth(); }
  static KeyframeImages Images() { return room_->Images(false); }
  static const Camera& camera() { return room_->camera(); }

  // The same, drifted: each step short by 3 % and turned 0.2 degrees more than the last.
  static std::vector<RefinedKeyframe> Drifted(const std::vector<RefinedKeyframe>& truth) {
    std::vector<RefinedKeyframe> drifted = truth;
    for (size_t k = 1; k < truth.size(); ++k) {
      Eigen::Isometry3d step =
          truth[k - 1].world_from_camera.inverse() * truth[k].world_from_camera;
      step.translation() *= 0.97;
      step.linear() =
          step.linear() * Eigen::AngleAxisd(0.2 * M_PI / 180.0, Eigen::Vector3d::UnitY()).matrix();
      drifted[k].world_from_camera = drifted[k - 1].world_from_camera * step;
    }
    return drifted;
  }

  // The largest distance of a keyframe's camera from the truth's [m].
  static double LargestError(const std::vector<RefinedKeyframe>& poses,
                             const std::vector<RefinedKeyframe>& truth) {
    double largest = 0.0;
    for (size_t k = 0; k < poses.size(); ++k) {
      largest = std::max(largest, (poses[k].world_from_camera.translation() -
                                   truth[k].world_from_camera.translation())
                                      .norm());
    }
    return largest;
  }

  static Rendered* room_;
};

Rendered* DenseRefinementTest::room_ = nullptr;

TEST_F(DenseRefinementTest, ADriftedPathComesBackToTheTruth) {
  const std::vector<RefinedKeyframe> truth = Truth();
  std::vector<RefinedKeyframe> poses = Drifted(truth);
  const double before = LargestError(poses, truth);
  ASSERT_GT(before, 0.01);
  DenseRefinementOptions options;
  options.enabled = true;
  options.span_drift_share = 0.0;  // the alignments alone (the spans: below)
  options.max_change_m = 0.05;
  options.max_change_deg = 1.0;
  const DenseRefinementFigures figures = RefineKeyframePoses(camera(), Images(), options, &poses);
  EXPECT_GT(figures.next_taken, figures.next_pairs / 2);
  EXPECT_LT(LargestError(poses, truth), 0.004) << "before: " << before << " m";
  EXPECT_LT(LargestError(poses, truth), before / 5.0);
}

TEST_F(DenseRefinementTest, AlignmentsFarFromThePosesAreNotTaken) {
  const std::vector<RefinedKeyframe> truth = Truth();
  const std::vector<RefinedKeyframe> drifted = Drifted(truth);
  std::vector<RefinedKeyframe> poses = drifted;
  DenseRefinementOptions options;
  options.enabled = true;
  options.max_change_m = 0.0005;  // the drift moves each pair by more
  options.max_change_deg = 0.01;
  options.revisit_max_change_m = 0.0005;
  options.revisit_max_change_deg = 0.01;
  const DenseRefinementFigures figures = RefineKeyframePoses(camera(), Images(), options, &poses);
  EXPECT_EQ(figures.next_taken + figures.revisit_taken, 0U);
  for (size_t k = 0; k < poses.size(); ++k) {
    EXPECT_TRUE(poses[k].world_from_camera.isApprox(drifted[k].world_from_camera)) << k;
  }
}

TEST_F(DenseRefinementTest, AlignmentsInTrianglesThatDoNotCloseAreNotTaken) {
  const std::vector<RefinedKeyframe> truth = Truth();
  std::vector<RefinedKeyframe> poses = Drifted(truth);
  DenseRefinementOptions options;
  options.enabled = true;
  options.span_drift_share = 0.0;  // the alignments alone (the spans: below)
  options.max_change_m = 0.05;     // alone, every alignment would be taken
  options.max_change_deg = 1.0;
  options.cycle_max_m = 0.0;  // no triangle closes
  DenseRefinementFigures figures = RefineKeyframePoses(camera(), Images(), options, &poses);
  EXPECT_EQ(figures.next_taken, 0U) << "of " << figures.next_pairs;
  options.next_keyframes = 1;  // no triangles: the change alone decides
  poses = Drifted(truth);
  const double before = LargestError(poses, truth);
  figures = RefineKeyframePoses(camera(), Images(), options, &poses, true);
  EXPECT_EQ(figures.next_taken, figures.next_pairs);
  EXPECT_LT(LargestError(poses, truth), before / 2.0);
}

// The floor's first frames: a corridor of blank walls and tiles, a person walking ahead (masked
// by the truth's masks). Keyframes every 3rd frame.
class CorridorRefinementTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { corridor_ = new Rendered("floor", 13, 3); }
  static void TearDownTestSuite() { delete corridor_; }
  static Rendered* corridor_;
};

Rendered* CorridorRefinementTest::corridor_ = nullptr;

// A keyframe put 8 cm off sideways, as a new segment's first tracked frames slide in a blank
// corridor: aligned on coarse cells first, its pairs find it again; on the fine cells alone,
// the alignment slides along the walls and is refused.
TEST_F(CorridorRefinementTest, AKeyframeFarOffSidewaysIsFoundAgainByACoarseAlignmentFirst) {
  const std::vector<RefinedKeyframe> truth = corridor_->Truth();
  std::vector<RefinedKeyframe> off = truth;
  off[2].world_from_camera = off[2].world_from_camera * Eigen::Translation3d(0.08, 0.0, 0.0);
  const auto error = [&truth](const std::vector<RefinedKeyframe>& poses) {
    return (poses[2].world_from_camera.translation() - truth[2].world_from_camera.translation())
        .norm();
  };
  DenseRefinementOptions options;
  options.span_drift_share = 0.0;  // the alignments alone
  options.coarse_cell_px = 8;
  std::vector<RefinedKeyframe> poses = off;
  RefineKeyframePoses(corridor_->camera(), corridor_->Images(true), options, &poses);
  EXPECT_LT(error(poses), 0.01);
  options.coarse_cell_px = 0;
  poses = off;
  RefineKeyframePoses(corridor_->camera(), corridor_->Images(true), options, &poses);
  EXPECT_GT(error(poses), 0.05);
}

TEST(CarryCorrectionsTest, FramesBetweenKeyframesMoveWithTheirCorrections) {
  Eigen::Isometry3d a = Eigen::Isometry3d::Identity(), b = Eigen::Isometry3d::Identity();
  b.translation() = Eigen::Vector3d(1.0, 0.0, 0.0);
  Eigen::Isometry3d b_after = b;
  b_after.translation() += Eigen::Vector3d(0.0, 0.2, 0.0);  // b moves 0.2 m, a stays
  std::vector<StampedPose> frames;
  for (int i = 0; i <= 4; ++i) {
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.translation() = Eigen::Vector3d(0.25 * i, 0.0, 0.0);
    frames.push_back({10.0 + i, pose});
  }
  Trajectory trajectory(frames);
  std::vector<bool> in_map(frames.size(), true);
  in_map[3] = false;  // a segment apart keeps its poses
  CarryCorrections({{0, a}, {1, b}}, {{0, a}, {1, b_after}}, {{0, 10.0}, {1, 14.0}}, in_map, {},
                   0.0, 10.0, &trajectory);
  const std::vector<StampedPose>& moved = trajectory.poses();
  EXPECT_NEAR(moved[0].world_from_camera.translation().y(), 0.0, 1e-12);
  EXPECT_NEAR(moved[2].world_from_camera.translation().y(), 0.1, 1e-12);
  EXPECT_NEAR(moved[3].world_from_camera.translation().y(), 0.0, 1e-12);
  EXPECT_NEAR(moved[4].world_from_camera.translation().y(), 0.2, 1e-12);
}

// Smoothed, a frame between keyframes takes their corrections averaged with Gaussian weights
// (recomputed here), a keyframe's frame its own correction, and a frame farther than three widths
// from every keyframe the nearest one's, faded as interpolated (to none 16 s past the last).
TEST(CarryCorrectionsTest, FramesBetweenKeyframesTakeTheirCorrectionsAveraged) {
  const std::vector<double> key_times = {10.0, 11.0, 12.0, 13.0, 14.0};
  const std::vector<double> shift_y = {0.01, -0.02, 0.03, 0.0, -0.01};  // each keyframe's own
  std::map<int, Eigen::Isometry3d> before, after;
  std::map<int, double> times;
  for (int k = 0; k < 5; ++k) {
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.translation() = Eigen::Vector3d(0.5 * k, 0.0, 0.0);
    before[k] = pose;
    pose.translation().y() += shift_y[static_cast<size_t>(k)];
    after[k] = pose;
    times[k] = key_times[static_cast<size_t>(k)];
  }
  const std::vector<double> frame_times = {12.0, 12.5, 30.0};
  std::vector<StampedPose> frames;
  frames.reserve(frame_times.size());
  for (const double t : frame_times) frames.push_back({t, Eigen::Isometry3d::Identity()});
  Trajectory trajectory(frames);
  CarryCorrections(before, after, times, std::vector<bool>(frames.size(), true), {}, 1.0, 3.0,
                   &trajectory);
  const std::vector<StampedPose>& moved = trajectory.poses();
  double weighted = 0.0, total = 0.0;
  for (size_t k = 0; k < key_times.size(); ++k) {
    const double w = std::exp(-0.5 * std::pow(key_times[k] - 12.5, 2.0));
    weighted += w * shift_y[k];
    total += w;
  }
  EXPECT_NEAR(moved[0].world_from_camera.translation().y(), 0.03, 1e-12);
  EXPECT_NEAR(moved[1].world_from_camera.translation().y(), weighted / total, 1e-12);
  EXPECT_NEAR(moved[2].world_from_camera.translation().y(), 0.0, 1e-12);
}

// Where a new map segment began (12.2 s), the frames after take the corrections of their own
// run's keyframes only, averaged or interpolated, and those before of theirs: the two runs were
// tracked on two chains. A run with no keyframe takes all of them, as without runs.
TEST(CarryCorrectionsTest, FramesTakeOnlyTheCorrectionsOfTheirOwnRun) {
  const std::vector<double> key_times = {10.0, 11.0, 12.0, 12.5, 13.0, 14.0};
  const std::vector<double> shift_y = {0.0, 0.0, 0.0, 0.3, 0.2, 0.1};  // the new run's moved
  std::map<int, Eigen::Isometry3d> before, after;
  std::map<int, double> times;
  for (int k = 0; k < 6; ++k) {
    before[k] = Eigen::Isometry3d::Identity();
    after[k] = Eigen::Isometry3d(Eigen::Translation3d(0.0, shift_y[static_cast<size_t>(k)], 0.0));
    times[k] = key_times[static_cast<size_t>(k)];
  }
  const std::vector<double> frame_times = {11.5, 12.1, 12.3, 12.75, 15.0};
  for (const double smoothing_s : {0.0, 3.0}) {
    std::vector<StampedPose> frames;
    frames.reserve(frame_times.size());
    for (const double t : frame_times) frames.push_back({t, Eigen::Isometry3d::Identity()});
    Trajectory trajectory(frames);
    CarryCorrections(before, after, times, std::vector<bool>(frames.size(), true), {12.2, 14.5},
                     smoothing_s, 3.0, &trajectory);
    const std::vector<StampedPose>& moved = trajectory.poses();
    const auto y = [&moved](size_t i) { return moved[i].world_from_camera.translation().y(); };
    EXPECT_NEAR(y(0), 0.0, 1e-12) << smoothing_s;  // the first run's keyframes did not move
    EXPECT_NEAR(y(1), 0.0, 1e-12) << smoothing_s;
    EXPECT_NEAR(y(2), 0.3 * (1.0 - 0.2 / 3.0), 1e-12) << smoothing_s;  // before its first: fading
    if (smoothing_s == 0.0) {
      EXPECT_NEAR(y(3), 0.25, 1e-12);  // interpolated between 0.3 and 0.2
    }
    EXPECT_GT(y(3), 0.2) << smoothing_s;  // averaged over 0.3, 0.2 and 0.1 only
    EXPECT_NEAR(y(4), 0.1 * (1.0 - 1.0 / 3.0), 1e-12) << smoothing_s;  // no keyframe: all of them
  }
}

// Each keyframe held to its pose: held as sure as the alignments, a drifted path moves only part
// of the way back to the truth; held loosely, it comes back as without the hold.
TEST_F(DenseRefinementTest, KeyframesHeldToTheirPosesMoveLess) {
  const std::vector<RefinedKeyframe> truth = Truth();
  DenseRefinementOptions options;
  options.enabled = true;
  options.span_drift_share = 0.0;  // the alignments alone (the spans: below)
  options.max_change_m = 0.05;
  options.max_change_deg = 1.0;
  const std::vector<RefinedKeyframe> drifted = Drifted(truth);
  const double before = LargestError(drifted, truth);
  std::vector<RefinedKeyframe> free = drifted;
  RefineKeyframePoses(camera(), Images(), options, &free);
  options.prior_sigma_m = options.alignment_sigma_m / 4.0;
  std::vector<RefinedKeyframe> held = drifted;
  RefineKeyframePoses(camera(), Images(), options, &held);
  EXPECT_GT(LargestError(held, truth), 2.0 * LargestError(free, truth));
  EXPECT_LT(LargestError(held, drifted), LargestError(free, drifted) / 2.0);
  options.prior_sigma_m = 1.0;
  std::vector<RefinedKeyframe> loose = drifted;
  RefineKeyframePoses(camera(), Images(), options, &loose);
  EXPECT_LT(LargestError(loose, truth), before / 5.0);
}

// Each keyframe held to the ones 2, 4, 8 after it, at the relative poses it has: held firmly, a
// drifted path stays as it was; held as sure as 3 % of the path between them (the drift lies
// within), the alignments bring it back to the truth.
TEST_F(DenseRefinementTest, SpansHoldThePathsShapeAndLetItsDriftGo) {
  const std::vector<RefinedKeyframe> truth = Truth();
  DenseRefinementOptions options;
  options.enabled = true;
  options.max_change_m = 0.05;
  options.max_change_deg = 1.0;
  options.prior_sigma_m = 0.0;
  const std::vector<RefinedKeyframe> drifted = Drifted(truth);
  const double before = LargestError(drifted, truth);
  options.span_drift_share = 0.03;
  std::vector<RefinedKeyframe> free = drifted;
  const DenseRefinementFigures figures = RefineKeyframePoses(camera(), Images(), options, &free);
  EXPECT_GT(figures.next_taken, figures.next_pairs / 2);
  EXPECT_LT(LargestError(free, truth), before / 3.0);
  options.span_drift_share = 1e-6;
  options.span_sigma_m = options.alignment_sigma_m / 10.0;
  options.span_rotation_sigma_deg = 0.001;
  options.span_rotation_drift_deg_per_m = 0.0;
  std::vector<RefinedKeyframe> firm = drifted;
  RefineKeyframePoses(camera(), Images(), options, &firm);
  EXPECT_LT(LargestError(firm, drifted), LargestError(free, drifted) / 3.0);
}

// Keyframes 10 s apart (frames between them tracked against older keyframes, as in a revisit):
// a frame takes the nearer keyframe's correction fading to none over the largest gap (3 s here),
// and so beyond the last keyframe; the same when frames between near keyframes are averaged
// (smoothing 3 s, the default), as these frames have no near keyframes on both sides.
TEST(CarryCorrectionsTest, FramesFarFromTheirKeyframesTakeLessOfTheirCorrection) {
  Eigen::Isometry3d a_after = Eigen::Isometry3d::Identity();
  a_after.translation() = Eigen::Vector3d(0.0, 0.3, 0.0);  // a moves 0.3 m, b stays
  std::vector<StampedPose> frames;
  for (const double time : {10.0, 11.0, 13.0, 15.0, 19.0, 20.0, 21.5}) {
    frames.push_back({time, Eigen::Isometry3d::Identity()});
  }
  const Eigen::Isometry3d at_rest = Eigen::Isometry3d::Identity();
  for (const double smoothing_s : {0.0, 3.0}) {
    Trajectory trajectory(frames);
    CarryCorrections({{0, at_rest}, {1, at_rest}}, {{0, a_after}, {1, at_rest}},
                     {{0, 10.0}, {1, 20.0}}, std::vector<bool>(frames.size(), true), {},
                     smoothing_s, 3.0, &trajectory);
    const std::vector<double> expected = {0.3, 0.2, 0.0, 0.0, 0.0, 0.0, 0.0};
    for (size_t i = 0; i < frames.size(); ++i) {
      EXPECT_NEAR(trajectory.poses()[i].world_from_camera.translation().y(), expected[i], 1e-12)
          << frames[i].time << " s, smoothing " << smoothing_s << " s";
    }
  }
}

// A relocalization that put every keyframe after it 5 cm off, as a person at the lens can: held
// at a tracked step's sureness, the poses' shape keeps part of the jump against the one
// alignment across it (17 mm of 50); marked as a step where tracking began anew, the alignment
// takes it out (3 mm).
TEST_F(DenseRefinementTest, AJumpWhereTrackingBeganAnewIsLeftToTheAlignments) {
  const std::vector<RefinedKeyframe> truth = Truth();
  std::vector<RefinedKeyframe> jumped = truth;
  const size_t relocalized = truth.size() / 2;
  for (size_t k = relocalized; k < truth.size(); ++k) {
    jumped[k].world_from_camera.translation() += Eigen::Vector3d(0.05, 0.0, 0.0);
  }
  const double before = LargestError(jumped, truth);
  DenseRefinementOptions options;
  options.enabled = true;
  options.next_keyframes = 1;  // one alignment across the jump, taken
  options.max_change_m = 0.1;
  options.max_change_deg = 3.0;
  options.anew_sigma_m = 0.0;  // as any other step
  std::vector<RefinedKeyframe> tracked = jumped;
  RefineKeyframePoses(camera(), Images(), options, &tracked);
  options.anew_sigma_m = 0.05;
  std::vector<RefinedKeyframe> anew = jumped;
  anew[relocalized].anew = true;
  const DenseRefinementFigures figures = RefineKeyframePoses(camera(), Images(), options, &anew);
  EXPECT_GT(figures.next_taken, figures.next_pairs / 2);
  EXPECT_GT(LargestError(tracked, truth), 0.005) << "before: " << before << " m";
  EXPECT_LT(LargestError(anew, truth), LargestError(tracked, truth) / 3.0);
  EXPECT_LT(LargestError(anew, truth), 0.005);
}

}  // namespace
}  // namespace stillmap
