// The semantic prior: motion levels (paper 002) and the YOLOX-Nano detector, checked against the
// ground-truth masks of rendered people. The model is read from ../shared/models (or
// $STILLMAP_MODELS); those tests skip when it is absent.
#include "stillmap/tracking/detector.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <iterator>
#include <opencv2/dnn.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "onnx_graph.h"
#include "rendered_sequence.h"
#include "stillmap/io/error.h"
#include "stillmap/io/sequence.h"
#include "test_util.h"
#include "yolox_net.h"

namespace stillmap {
namespace {

TEST(MotionLevelTest, PaperLevelsAndOverrides) {
  MotionLevelTable table = MotionLevelTable::Default();
  EXPECT_EQ(table.Level("person"), MotionLevel::kHigh);
  EXPECT_EQ(table.Level("dog"), MotionLevel::kHigh);
  EXPECT_EQ(table.Level("chair"), MotionLevel::kMedium);
  EXPECT_EQ(table.Level("keyboard"), MotionLevel::kMedium);
  EXPECT_EQ(table.Level("tvmonitor"), MotionLevel::kLow);
  EXPECT_EQ(table.Level("refrigerator"), MotionLevel::kLow);
  table.Set("chair", "low");
  EXPECT_EQ(table.Level("chair"), MotionLevel::kLow);
  EXPECT_THROW(table.Set("chair", "fast"), InputError);
}

TEST(YoloxDetectorTest, MissingModelIsNamed) {
  testing::TempDir dir;
  try {
    MakeYoloxDetector(dir.path(), MotionLevelTable::Default());
    FAIL() << "no error for a missing model";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("yolox_nano.onnx"), std::string::npos) << e.what();
  }
}

// On rendered people with exact masks; this also checks that the synthetic people of issue 3 look
// like people to the model (box-shaped people scored below 0.04, the rounded, faced ones 0.5-0.9).
// Decoding: every person box lies on a person (a third of its area or more is person pixels;
// people fill about half of their box). Recall is a property of the model on these renderings
// rather than of the code: where people cover at least 5 % of the frame, a person box lies on
// them in 17 of 24 sampled frames and holds 80 % of their pixels in 13. People seen from the side
// at the image border are missed, or taken for chairs; issue 5's geometric checks and the
// carrying of masks between frames are there for those.
void ExpectPersonBoxesOnRenderedPeople(Detector* detector) {
  testing::TempDir dir;
  const Sequence sequence = testing::RenderSequence(dir / "seq", "walking_xyz", 240);
  int frames = 0, seen = 0, covered = 0, person_boxes = 0, boxes_on_people = 0;
  for (size_t i = 0; i < sequence.frames().size(); i += 10) {
    const cv::Mat mask = testing::MovingObjectMask(dir / "seq", sequence, i);
    cv::Mat high(mask.size(), CV_8UC1, cv::Scalar(0));
    for (const Detection& detection :
         detector->Detect(cv::imread(sequence.frames()[i].color_path))) {
      if (detection.level != MotionLevel::kHigh) continue;
      const cv::Rect box(detection.box);
      high(box).setTo(255);
      ++person_boxes;
      boxes_on_people += cv::countNonZero(mask(box)) >= box.area() / 3;
    }
    const int person_pixels = cv::countNonZero(mask);
    if (person_pixels < 0.05 * static_cast<double>(mask.total())) continue;
    ++frames;
    seen += cv::countNonZero(mask & high) > 0;
    covered += cv::countNonZero(mask & high) >= 0.8 * person_pixels;
  }
  std::cout << boxes_on_people << " of " << person_boxes << " person boxes lie on people; of "
            << frames << " frames with people, " << seen << " have a person box on them, "
            << covered << " hold 80 % of them in boxes\n";
  ASSERT_GE(person_boxes, 10);
  EXPECT_GE(boxes_on_people, 0.9 * person_boxes);
  ASSERT_GE(frames, 10);
  EXPECT_GE(seen, 0.6 * frames);  // the rendered people look like people to the model
  EXPECT_GE(covered, 0.5 * frames);
}

TEST(YoloxDetectorTest, PersonBoxesLieOnTheRenderedPeople) {
  const auto models = testing::SharedModels("yolox_nano");
  if (!models) GTEST_SKIP() << "yolox_nano not found (set STILLMAP_MODELS or ../shared/models)";
  ExpectPersonBoxesOnRenderedPeople(MakeYoloxDetector(*models, MotionLevelTable::Default()).get());
}

// Yolo-Fastest on the same renderings, with the same bars.
TEST(FastestDetectorTest, PersonBoxesLieOnTheRenderedPeople) {
  const auto models = testing::SharedModels("yolo_fastest_1.1");
  if (!models) {
    GTEST_SKIP() << "yolo_fastest_1.1 not found (set STILLMAP_MODELS or ../shared/models)";
  }
  ExpectPersonBoxesOnRenderedPeople(
      MakeFastestDetector(*models, MotionLevelTable::Default()).get());
}

TEST(FastestDetectorTest, MissingOrDamagedModelIsNamed) {
  testing::TempDir dir;
  auto error_of = [&dir]() -> std::string {
    try {
      MakeFastestDetector(dir.path(), MotionLevelTable::Default());
    } catch (const InputError& e) {
      return e.what();
    }
    return "no error";
  };
  EXPECT_NE(error_of().find("yolo-fastest-1.1.cfg"), std::string::npos) << error_of();
  const std::filesystem::path folder = std::filesystem::path(dir.path()) / "yolo_fastest_1.1";
  std::filesystem::create_directories(folder);
  testing::WriteText((folder / "yolo-fastest-1.1.cfg").string(), "[net]\nwidth=oops\n");
  EXPECT_NE(error_of().find("yolo-fastest-1.1.weights"), std::string::npos) << error_of();
  testing::WriteText((folder / "yolo-fastest-1.1.weights").string(), "not weights");
  testing::WriteText((folder / "coco.names").string(), "person\n");
  EXPECT_NE(error_of().find("cannot read them as a Darknet model"), std::string::npos)
      << error_of();
  // The real configuration with its weights cut short (OpenCV itself reads them without a word).
  const auto models = testing::SharedModels("yolo_fastest_1.1");
  if (!models) GTEST_SKIP() << "yolo_fastest_1.1 not found: the cut weights are not tried";
  const std::filesystem::path real = std::filesystem::path(*models) / "yolo_fastest_1.1";
  std::filesystem::copy_file(real / "yolo-fastest-1.1.cfg", folder / "yolo-fastest-1.1.cfg",
                             std::filesystem::copy_options::overwrite_existing);
  std::filesystem::copy_file(real / "coco.names", folder / "coco.names",
                             std::filesystem::copy_options::overwrite_existing);
  std::filesystem::copy_file(real / "yolo-fastest-1.1.weights", folder / "yolo-fastest-1.1.weights",
                             std::filesystem::copy_options::overwrite_existing);
  EXPECT_NO_THROW(MakeFastestDetector(dir.path(), MotionLevelTable::Default()));
  // One weight's exponent byte damaged (bytes 1000-1003: -0.55 becomes -4e22).
  std::string weights = testing::ReadText((folder / "yolo-fastest-1.1.weights").string());
  weights[1003] = static_cast<char>(weights[1003] ^ 0x5a);
  testing::WriteText((folder / "yolo-fastest-1.1.weights").string(), weights);
  EXPECT_NE(error_of().find("not finite or beyond 1e6"), std::string::npos) << error_of();
  std::filesystem::resize_file(folder / "yolo-fastest-1.1.weights", 700000);
  EXPECT_NE(error_of().find("cut short"), std::string::npos) << error_of();
}

// People who fill a large part of the frame (the synthetic loop walks the camera past people
// along the walls, frames 420-460): at 320x256 alone Yolo-Fastest covers half of the person in 6
// of the 17 frames tried here, with the coarse 160x128 pass in 14 (it adds only what the first
// pass did not find).
TEST(FastestDetectorTest, CoarsePassFindsPeopleNearTheLens) {
  const auto models = testing::SharedModels("yolo_fastest_1.1");
  if (!models) {
    GTEST_SKIP() << "yolo_fastest_1.1 not found (set STILLMAP_MODELS or ../shared/models)";
  }
  testing::TempDir dir;
  const Sequence sequence = testing::RenderSequence(dir / "seq", "loop", 462);
  FastestOptions fine_only;
  fine_only.coarse_input_width = 0;
  fine_only.coarse_input_height = 0;
  const auto both = MakeFastestDetector(*models, MotionLevelTable::Default());
  const auto fine = MakeFastestDetector(*models, MotionLevelTable::Default(), fine_only);
  int frames = 0, covered_both = 0, covered_fine = 0;
  for (size_t i = 420; i < sequence.frames().size(); i += 2) {
    const cv::Mat mask = testing::MovingObjectMask(dir / "seq", sequence, i);
    const int person_pixels = cv::countNonZero(mask);
    if (person_pixels < 0.1 * static_cast<double>(mask.total())) continue;
    const cv::Mat image = cv::imread(sequence.frames()[i].color_path);
    const auto covers = [&](Detector* detector) {
      cv::Mat high(mask.size(), CV_8UC1, cv::Scalar(0));
      for (const Detection& detection : detector->Detect(image)) {
        if (detection.level == MotionLevel::kHigh) high(cv::Rect(detection.box)).setTo(255);
      }
      return cv::countNonZero(mask & high) >= 0.5 * person_pixels;
    };
    ++frames;
    covered_both += covers(both.get());
    covered_fine += covers(fine.get());
  }
  std::cout << "of " << frames << " frames with a person near the lens, both passes cover half "
            << "of the person in " << covered_both << ", the 320x256 pass alone in " << covered_fine
            << "\n";
  ASSERT_GE(frames, 12);
  EXPECT_GE(covered_both, 0.6 * frames);
  EXPECT_GE(covered_both, covered_fine + frames / 4);
}

// auto: Yolo-Fastest with YOLOX-Nano as its second opinion when both are there, else the one
// that is, else none.
TEST(DetectorChoiceTest, AutoPrefersYoloFastestWithYoloxThenEither) {
  testing::TempDir dir;
  EXPECT_EQ(ResolveDetectorName("auto", dir.path()), "none");
  std::filesystem::create_directories(dir / "yolox_nano");
  testing::WriteText(dir / "yolox_nano/yolox_nano.onnx", "x");
  testing::WriteText(dir / "yolox_nano/coco.names", "person\n");
  EXPECT_EQ(ResolveDetectorName("auto", dir.path()), "yolox");
  std::filesystem::create_directories(dir / "yolo_fastest_1.1");
  testing::WriteText(dir / "yolo_fastest_1.1/yolo-fastest-1.1.cfg", "x");
  testing::WriteText(dir / "yolo_fastest_1.1/coco.names", "person\n");
  EXPECT_EQ(ResolveDetectorName("auto", dir.path()), "yolox");  // no weights yet
  testing::WriteText(dir / "yolo_fastest_1.1/yolo-fastest-1.1.weights", "x");
  EXPECT_EQ(ResolveDetectorName("auto", dir.path()), "yolo-fastest+yolox");
  EXPECT_EQ(ResolveDetectorName("yolox", dir.path()), "yolox");
  std::filesystem::remove_all(dir / "yolox_nano");
  EXPECT_EQ(ResolveDetectorName("auto", dir.path()), "yolo-fastest");
}

// Fixed detections, counting the runs.
class FixedDetector : public Detector {
 public:
  FixedDetector(std::string name, std::vector<Detection> detections)
      : name_(std::move(name)), detections_(std::move(detections)) {}
  std::vector<Detection> Detect(const cv::Mat&) override {
    ++runs;
    return detections_;
  }
  std::string name() const override { return name_; }
  int runs = 0;

 private:
  std::string name_;
  std::vector<Detection> detections_;
};

Detection Box(const std::string& name, MotionLevel level, float x, float y, float w, float h) {
  Detection detection;
  detection.box = cv::Rect2f(x, y, w, h);
  detection.name = name;
  detection.class_id = name == "person" ? 0 : 56;
  detection.level = level;
  return detection;
}

// Asked, the second detector's people join the first's: one both found takes the box holding
// both (the first's held only part of them), one only the second found is added; the second's
// other classes are not. Not asked, only the first runs.
TEST(SecondOpinionTest, PeopleOfTheSecondDetectorJoinTheFirstOnes) {
  const Detection part = Box("person", MotionLevel::kHigh, 100, 100, 40, 60);
  const Detection chair = Box("chair", MotionLevel::kMedium, 300, 200, 50, 50);
  auto first = std::make_unique<FixedDetector>("fast", std::vector<Detection>{part, chair});
  auto second = std::make_unique<FixedDetector>(
      "strong", std::vector<Detection>{Box("person", MotionLevel::kHigh, 90, 40, 70, 200),
                                       Box("person", MotionLevel::kHigh, 0, 20, 60, 300),
                                       Box("chair", MotionLevel::kMedium, 500, 200, 50, 50)});
  FixedDetector* first_runs = first.get();
  FixedDetector* second_runs = second.get();
  const auto detector = MakeSecondOpinionDetector(std::move(first), std::move(second));
  EXPECT_EQ(detector->name(), "fast+strong");
  EXPECT_TRUE(detector->has_second_opinion());
  const cv::Mat image(480, 640, CV_8UC3, cv::Scalar(0, 0, 0));

  const std::vector<Detection> alone = detector->Detect(image);
  ASSERT_EQ(alone.size(), 2u);
  EXPECT_EQ(alone[0].box, part.box);
  EXPECT_EQ(second_runs->runs, 0);

  const std::vector<Detection> both = detector->DetectWithSecondOpinion(image);
  EXPECT_EQ(first_runs->runs, 2);
  EXPECT_EQ(second_runs->runs, 1);
  ASSERT_EQ(both.size(), 3u);
  EXPECT_EQ(both[0].box, cv::Rect2f(90, 40, 70, 200));  // holds the part (100..140, 100..160)
  EXPECT_EQ(both[1].box, chair.box);
  EXPECT_EQ(both[2].box, cv::Rect2f(0, 20, 60, 300));
  EXPECT_EQ(both[2].level, MotionLevel::kHigh);
}

// The share of the moving pixels that person boxes hold (tentative ones left out, as the masker
// leaves them out on their first run), summed over frames.
double PersonBoxCoverage(const std::vector<Detection>& detections, const cv::Mat& truth) {
  cv::Mat boxes(truth.size(), CV_8UC1, cv::Scalar(0));
  for (const Detection& detection : detections) {
    if (detection.level != MotionLevel::kHigh || detection.tentative) continue;
    boxes(cv::Rect(detection.box) & cv::Rect(cv::Point(0, 0), truth.size())).setTo(255);
  }
  return cv::countNonZero(boxes & truth) / static_cast<double>(cv::countNonZero(truth));
}

// Issue 51: the two detectors miss different people, so the default's second opinion holds more
// of them than either alone. busy_office's frames in which people cover a fifth of the image or
// more as one of them comes up to the lens (4.3-5.7 s), against the exact masks. Measured: boxes
// hold 0.36 of the moving pixels with Yolo-Fastest, 0.40 with YOLOX, 0.56 with both (18 frames;
// over the whole sequence 0.58, 0.55 and 0.73: docs/figures.md).
TEST(SecondOpinionTest, BothDetectorsHoldMoreOfThePeopleNearTheLensThanEither) {
  const auto models = testing::SharedModels("yolo_fastest_1.1");
  if (!models || !HoldsYolox(*models)) GTEST_SKIP() << "yolo_fastest_1.1 or yolox_nano not found";
  testing::TempDir dir;
  const Sequence sequence = testing::RenderSequence(dir / "seq", "busy_office", 170);
  const auto fastest = MakeFastestDetector(*models, MotionLevelTable::Default());
  const auto yolox = MakeYoloxDetector(*models, MotionLevelTable::Default());
  const auto both = MakeDetector("yolo-fastest+yolox", *models, MotionLevelTable::Default(), {});
  double fastest_sum = 0.0, yolox_sum = 0.0, both_sum = 0.0;
  int frames = 0;
  for (size_t i = 130; i < sequence.frames().size(); i += 2) {
    const cv::Mat truth = testing::MovingObjectMask(dir / "seq", sequence, i);
    if (cv::countNonZero(truth) < 0.2 * static_cast<double>(truth.total())) continue;
    const cv::Mat image = cv::imread(sequence.frames()[i].color_path);
    fastest_sum += PersonBoxCoverage(fastest->Detect(image), truth);
    yolox_sum += PersonBoxCoverage(yolox->Detect(image), truth);
    both_sum += PersonBoxCoverage(both->DetectWithSecondOpinion(image), truth);
    ++frames;
  }
  std::cout << frames << " frames with people near the lens: person boxes hold "
            << fastest_sum / frames << " of them with Yolo-Fastest, " << yolox_sum / frames
            << " with YOLOX, " << both_sum / frames << " with both\n";
  ASSERT_GE(frames, 10);
  EXPECT_GE(both_sum, fastest_sum + 0.05 * frames);
  EXPECT_GE(both_sum, yolox_sum + 0.05 * frames);
}

// Where Yolo-Fastest misses people on real frames and YOLOX does not (the second opinion's
// reason, issue 51): every second frame of bonn_crowd_a, each detector's person boxes against the
// other's (the same person when half of the smaller box or more is shared). Measured: 424 boxes
// each; 11 only YOLOX found, all at the left or right border, in 11 frames.
TEST(SecondOpinionTest, PeopleOnlyYoloxFindsInTheCrowdAreAtTheBorder) {
  const auto models = testing::SharedModels("yolo_fastest_1.1");
  const auto bonn = testing::SharedSequence("bonn_crowd_a");
  if (!models || !HoldsYolox(*models) || !bonn) {
    GTEST_SKIP() << "yolo_fastest_1.1, yolox_nano or bonn_crowd_a not found";
  }
  const auto fastest = MakeFastestDetector(*models, MotionLevelTable::Default());
  const auto yolox = MakeYoloxDetector(*models, MotionLevelTable::Default());
  const Sequence sequence = Sequence::Open(*bonn, ResolveCamera(*bonn, {}));
  auto people = [](Detector* detector, const cv::Mat& image) {
    std::vector<Detection> found;
    for (Detection& detection : detector->Detect(image)) {
      if (detection.level == MotionLevel::kHigh) found.push_back(std::move(detection));
    }
    return found;
  };
  auto lies_on_any = [](const Detection& person, const std::vector<Detection>& others) {
    return std::any_of(others.begin(), others.end(), [&person](const Detection& other) {
      const float shared = (other.box & person.box).area();
      return shared >= 0.5f * std::min(other.box.area(), person.box.area());
    });
  };
  int yolox_boxes = 0, yolox_only = 0, yolox_only_at_border = 0;
  for (size_t i = 0; i < sequence.frames().size(); i += 2) {
    const cv::Mat image = cv::imread(sequence.frames()[i].color_path);
    const std::vector<Detection> fast = people(fastest.get(), image);
    for (const Detection& person : people(yolox.get(), image)) {
      ++yolox_boxes;
      if (lies_on_any(person, fast)) continue;
      ++yolox_only;
      const cv::Rect2f& box = person.box;
      yolox_only_at_border += box.x <= 2.0f || box.x + box.width >= image.cols - 2.0f;
    }
  }
  std::cout << "bonn_crowd_a, every second frame: " << yolox_boxes << " YOLOX person boxes, "
            << yolox_only << " that Yolo-Fastest has not, " << yolox_only_at_border
            << " of them at the left or right border\n";
  ASSERT_GE(yolox_boxes, 300);
  EXPECT_GE(yolox_only, 5);
  EXPECT_GE(yolox_only_at_border, 0.8 * yolox_only);
}

// The rewritten YOLOX-Nano (yolox_net.h, onnx_graph.h) on the shared model: both rewrites taken
// (every SiLU fused, the slicing stem cut), and OpenCV's output on real frames (teddy, letterboxed
// as the detector does) the same as the original graph's.
TEST(YoloxDetectorTest, RewrittenNetworkGivesTheOriginalOutput) {
  const auto models = testing::SharedModels("yolox_nano");
  const auto teddy = testing::SharedSequence("tum_fr3_teddy_200");
  if (!models || !teddy) GTEST_SKIP() << "yolox_nano or tum_fr3_teddy_200 not found";
  const std::string path = (std::filesystem::path(*models) / "yolox_nano/yolox_nano.onnx").string();
  std::ifstream in(path, std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  int fused_pairs = 0;
  EXPECT_NE(FuseSwish(bytes, &fused_pairs), bytes);
  EXPECT_EQ(fused_pairs, 104);
  SliceStem stem;
  EXPECT_NE(CutSliceStem(bytes, 320, 416, &stem), bytes);
  EXPECT_EQ(stem.node, "Concat_40");
  cv::dnn::Net original = cv::dnn::readNetFromONNX(path);
  YoloxNet rewritten(cv::dnn::readNetFromONNX(path), path, 320, 416);
  EXPECT_TRUE(rewritten.activations_fused());
  EXPECT_TRUE(rewritten.stem_cut());
  const Sequence sequence = Sequence::Open(*teddy, ResolveCamera(*teddy, {}));
  for (size_t frame : {0, 100}) {
    const cv::Mat bgr = cv::imread(sequence.frames()[frame].color_path);
    cv::Mat canvas(320, 416, CV_8UC3, cv::Scalar(114, 114, 114));
    cv::Mat resized;
    cv::resize(bgr, resized, cv::Size(), 0.65, 0.65, cv::INTER_LINEAR);
    resized.copyTo(canvas(cv::Rect(0, 0, resized.cols, resized.rows)));
    original.setInput(cv::dnn::blobFromImage(canvas, 1.0, cv::Size(), cv::Scalar(), false));
    const cv::Mat expected = original.forward().clone();
    const cv::Mat got = rewritten.Forward(canvas);
    ASSERT_EQ(got.size, expected.size);
    const double largest = cv::norm(expected, cv::NORM_INF);
    EXPECT_LE(cv::norm(got, expected, cv::NORM_INF), 1e-4 * largest) << "frame " << frame;
  }
}

TEST(DeeplabDetectorTest, MissingModelIsNamed) {
  testing::TempDir dir;
  try {
    MakeDeeplabDetector(dir.path(), MotionLevelTable::Default());
    FAIL() << "no error for a missing model";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("deeplab_v3_mnv2_voc_opencv46.onnx"), std::string::npos)
        << e.what();
  }
}

// Per-pixel person labels against the exact masks of rendered people: segments carry their own
// pixels (each mask lies inside its box), and the person pixels are mostly on people.
TEST(DeeplabDetectorTest, PersonSegmentsLieOnTheRenderedPeople) {
  const auto models = testing::SharedModels("deeplabv3_mnv2_voc");
  if (!models) {
    GTEST_SKIP() << "deeplabv3_mnv2_voc not found (set STILLMAP_MODELS or ../shared/models)";
  }
  const std::unique_ptr<Detector> detector =
      MakeDeeplabDetector(*models, MotionLevelTable::Default());
  testing::TempDir dir;
  const Sequence sequence = testing::RenderSequence(dir / "seq", "walking_xyz", 240);
  double labelled = 0, correct = 0, person_pixels = 0;
  for (size_t i = 0; i < sequence.frames().size(); i += 10) {
    const cv::Mat truth = testing::MovingObjectMask(dir / "seq", sequence, i);
    cv::Mat person(truth.size(), CV_8UC1, cv::Scalar(0));
    for (const Detection& detection :
         detector->Detect(cv::imread(sequence.frames()[i].color_path))) {
      ASSERT_EQ(detection.mask.size(), cv::Rect(detection.box).size());
      ASSERT_GT(cv::countNonZero(detection.mask), 0);
      if (detection.name != "person") continue;
      EXPECT_EQ(detection.level, MotionLevel::kHigh);
      person(cv::Rect(detection.box)).setTo(255, detection.mask);
    }
    labelled += cv::countNonZero(person);
    correct += cv::countNonZero(person & truth);
    person_pixels += cv::countNonZero(truth);
  }
  std::cout << "DeepLab person pixels: precision " << correct / std::max(labelled, 1.0)
            << ", recall " << correct / std::max(person_pixels, 1.0) << "\n";
  ASSERT_GT(labelled, 0);
  EXPECT_GE(correct / labelled, 0.8);
}

}  // namespace
}  // namespace stillmap
