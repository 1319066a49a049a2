// The detector's schedule (issue 17): which frames are detected, when their detections are used,
// and how they are carried to that frame, in place and in the background.
#include "stillmap/tracking/detection_schedule.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <opencv2/imgproc.hpp>
#include <thread>

#include "stillmap/tracking/mask_stage.h"
#include "test_util.h"

namespace stillmap {
namespace {

// Reports one box whose x is the image's first pixel value (the frame number), after a delay
// that varies from run to run, so that a schedule relying on timing would show it.
class FrameNumberDetector : public Detector {
 public:
  explicit FrameNumberDetector(std::atomic<int>* calls) : calls_(calls) {}
  std::vector<Detection> Detect(const cv::Mat& bgr) override {
    const int call = (*calls_)++;
    std::this_thread::sleep_for(std::chrono::milliseconds(call % 2 == 0 ? 30 : 1));
    Detection detection;
    detection.box = cv::Rect2f(static_cast<float>(bgr.at<cv::Vec3b>(0, 0)[0]), 10.0f, 40.0f, 40.0f);
    detection.name = "person";
    detection.level = MotionLevel::kHigh;
    return {detection};
  }
  std::string name() const override { return "frame-number"; }

 private:
  std::atomic<int>* calls_;
};

cv::Mat FrameImage(int frame) { return cv::Mat(120, 160, CV_8UC3, cv::Scalar(frame, 0, 0)); }

// Points on a 5 px grid over the image, every one moved right by shift_px.
FlowStep UniformStep(float shift_px) {
  FlowStep step;
  for (float y = 2.0f; y < 120.0f; y += 5.0f) {
    for (float x = 2.0f; x < 160.0f; x += 5.0f) {
      step.from.emplace_back(x, y);
      step.result.current.emplace_back(x + shift_px, y);
      step.result.tracked.push_back(1);
    }
  }
  return step;
}

// Frame -> the x of the box returned there (or -1 when nothing was returned).
std::vector<float> RunSchedule(int interval, bool background, int frames, float shift_px) {
  std::atomic<int> calls{0};
  DetectionSchedule schedule(std::make_unique<FrameNumberDetector>(&calls), interval, background);
  std::vector<float> box_x;
  for (int frame = 0; frame < frames; ++frame) {
    const FlowStep step = UniformStep(shift_px);
    const std::optional<DetectorRun> run = schedule.Next(FrameImage(frame), &step);
    if (!run) {
      box_x.push_back(-1.0f);
      continue;
    }
    EXPECT_EQ(run->detections.size(), 1u);
    box_x.push_back(run->detections.empty() ? -2.0f : run->detections[0].box.x);
  }
  return box_x;
}

TEST(DetectionScheduleTest, InPlaceDetectsEveryIntervalFrameAndReturnsItAtOnce) {
  const std::vector<float> box_x = RunSchedule(3, false, 8, 2.0f);
  const std::vector<float> expected = {0, -1, -1, 3, -1, -1, 6, -1};
  EXPECT_EQ(box_x, expected);
}

TEST(DetectionScheduleTest, BackgroundUsesEachRunIntervalFramesLaterCarriedByFlow) {
  // Frame 0 in place; frame 3's run is used at frame 6, its box carried by the flow of frames
  // 4, 5 and 6 (2 px each); frame 6's at frame 9.
  const std::vector<float> box_x = RunSchedule(3, true, 10, 2.0f);
  const std::vector<float> expected = {0, -1, -1, -1, -1, -1, 3 + 6, -1, -1, 6 + 6};
  EXPECT_EQ(box_x, expected);
}

TEST(DetectionScheduleTest, BackgroundRepeatsWhateverTheTiming) {
  for (int run = 0; run < 3; ++run) {
    EXPECT_EQ(RunSchedule(2, true, 12, 1.5f), RunSchedule(2, true, 12, 1.5f));
  }
}

TEST(DetectionScheduleTest, WithoutFlowBackgroundDetectionsAreUsedUncarried) {
  std::atomic<int> calls{0};
  std::vector<float> box_x;
  {
    DetectionSchedule schedule(std::make_unique<FrameNumberDetector>(&calls), 2, true);
    for (int frame = 0; frame < 5; ++frame) {
      const std::optional<DetectorRun> run = schedule.Next(FrameImage(frame), nullptr);
      box_x.push_back(run ? run->detections.at(0).box.x : -1.0f);
    }
  }  // waits for the run still in flight
  const std::vector<float> expected = {0, -1, -1, -1, 2};
  EXPECT_EQ(box_x, expected);
  EXPECT_EQ(calls.load(), 3);  // frames 0, 2 and 4
}

// A detector with a second opinion that records the frames (first pixel value) it was asked on.
class AskedFramesDetector : public Detector {
 public:
  explicit AskedFramesDetector(std::vector<int>* asked) : asked_(asked) {}
  std::vector<Detection> Detect(const cv::Mat&) override { return {}; }
  std::string name() const override { return "asked-frames"; }
  bool has_second_opinion() const override { return true; }
  std::vector<Detection> DetectWithSecondOpinion(const cv::Mat& bgr) override {
    asked_->push_back(bgr.at<cv::Vec3b>(0, 0)[0]);
    return {};
  }

 private:
  std::vector<int>* asked_;
};

// The frames asked while wanted: as many as the share allows, counted over the runs so far (at
// 0.25: the 4th, 8th, 12th, 16th and 20th run). In the background the same runs, whatever the
// timing.
std::vector<int> AskedFrames(int interval, bool background, bool wanted, size_t* second_runs) {
  std::vector<int> asked;
  {
    DetectionSchedule schedule(std::make_unique<AskedFramesDetector>(&asked), interval, background,
                               true, 0.25);
    // In the background one frame more, for the last run's result to be taken.
    const int frames = 20 * interval + (background ? 1 : 0);
    for (int frame = 0; frame < frames; ++frame) {
      schedule.Next(FrameImage(frame), nullptr, wanted);
    }
    EXPECT_EQ(schedule.runs(), background ? 21u : 20u);
    *second_runs = schedule.second_opinion_runs();
  }  // waits for the run in flight
  std::sort(asked.begin(), asked.end());
  return asked;
}

TEST(DetectionScheduleTest, SecondOpinionWhereWantedWithinItsShare) {
  size_t second_runs = 0;
  EXPECT_EQ(AskedFrames(1, false, true, &second_runs), (std::vector<int>{3, 7, 11, 15, 19}));
  EXPECT_EQ(second_runs, 5u);
  EXPECT_EQ(AskedFrames(2, true, true, &second_runs), (std::vector<int>{6, 14, 22, 30, 38}));
  EXPECT_EQ(second_runs, 5u);
  EXPECT_EQ(AskedFrames(1, false, false, &second_runs), (std::vector<int>{}));
  EXPECT_EQ(second_runs, 0u);
  // A detector without a second opinion is never asked.
  std::atomic<int> calls{0};
  DetectionSchedule plain(std::make_unique<FrameNumberDetector>(&calls), 1, false, true, 1.0);
  for (int frame = 0; frame < 4; ++frame) plain.Next(FrameImage(frame), nullptr, true);
  EXPECT_EQ(plain.second_opinion_runs(), 0u);
}

// masking.flow_klt_window 0 (the default) is resolved by the mask stage: 15 px with a detector,
// 21 px without; a window set by the user is kept either way. So is masking.flow_points: 300
// corners with a detector, 400 without.
TEST(MaskStageTest, KltWindowAndFlowPointsFollowTheDetector) {
  const Camera camera = testing::SmallCamera(160, 120);
  std::atomic<int> calls{0};
  const DynamicMaskOptions defaults;
  const MaskStage with(camera, defaults, true, std::make_unique<FrameNumberDetector>(&calls), false,
                       "");
  EXPECT_EQ(with.options().flow.klt_window, kKltWindowWithDetector);
  EXPECT_EQ(with.options().flow_points, kFlowPointsWithDetector);
  const MaskStage without(camera, defaults, true, nullptr, false, "");
  EXPECT_EQ(without.options().flow.klt_window, kKltWindowGeometryOnly);
  EXPECT_EQ(without.options().flow_points, kFlowPointsGeometryOnly);
  DynamicMaskOptions set;
  set.flow.klt_window = 9;
  set.flow_points = 120;
  const MaskStage kept(camera, set, true, std::make_unique<FrameNumberDetector>(&calls), false, "");
  EXPECT_EQ(kept.options().flow.klt_window, 9);
  EXPECT_EQ(kept.options().flow_points, 120);
  const MaskStage kept_without(camera, set, true, nullptr, false, "");
  EXPECT_EQ(kept_without.options().flow_points, 120);
  EXPECT_EQ(kKltWindowWithDetector, 15);
  EXPECT_EQ(kKltWindowGeometryOnly, 21);
  EXPECT_EQ(kFlowPointsWithDetector, 300);
  EXPECT_EQ(kFlowPointsGeometryOnly, 400);
}

// After the last frame the stage frees its detector (with its network) and the depth check's
// references; its name and figures stay for the report.
TEST(MaskStageTest, EndFramesFreesTheDetectorAndKeepsTheFigures) {
  class Watched : public FrameNumberDetector {
   public:
    Watched(std::atomic<int>* calls, bool* freed) : FrameNumberDetector(calls), freed_(freed) {}
    ~Watched() override { *freed_ = true; }

   private:
    bool* freed_;
  };
  const Camera camera = testing::SmallCamera(160, 120);
  std::atomic<int> calls{0};
  bool freed = false;
  MaskStage stage(camera, DynamicMaskOptions{}, true, std::make_unique<Watched>(&calls, &freed),
                  false, "");
  for (int k = 0; k < 3; ++k) {
    Frame frame{static_cast<size_t>(k), 0.1 * k, FrameImage(k),
                cv::Mat(120, 160, CV_32F, cv::Scalar(2.0f))};
    cv::Mat gray;
    cv::cvtColor(frame.color, gray, cv::COLOR_BGR2GRAY);
    const cv::Mat mask = stage.Compute(frame, gray, nullptr, Eigen::Isometry3d::Identity());
    stage.AddReference(frame, mask, Eigen::Isometry3d::Identity(), k);
  }
  const MaskingStatistics before = stage.statistics();
  ASSERT_GT(before.detector_runs, 0u);
  ASSERT_FALSE(stage.masker()->References().empty());
  stage.EndFrames();
  EXPECT_TRUE(freed);
  EXPECT_TRUE(stage.masker()->References().empty());
  EXPECT_EQ(stage.detector_name(), "frame-number");
  EXPECT_TRUE(stage.semantics());
  EXPECT_EQ(stage.statistics().frames, before.frames);
  EXPECT_EQ(stage.statistics().detector_runs, before.detector_runs);
}

}  // namespace
}  // namespace stillmap
