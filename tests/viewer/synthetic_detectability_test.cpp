// The synthetic people must look like people to the detector the pipeline uses (issue 5):
// YOLOX-Nano from ../shared/models (or $STILLMAP_MODELS) finds a person in most frames where one
// is sizeably visible. Measured when written: box-shaped people scored below 0.04, the rounded,
// faced people 0.5-0.9. The decoding follows the model's PROVENANCE.txt.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <opencv2/dnn.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "stillmap/io/sequence.h"
#include "stillmap/viewer/synthetic.h"
#include "test_util.h"

namespace stillmap {
namespace {

namespace fs = std::filesystem;

std::optional<std::string> YoloxModel() {
  const char* env = std::getenv("STILLMAP_MODELS");
  const fs::path root =
      env != nullptr ? fs::path(env) : fs::path(STILLMAP_SHARED_DATA) / "../models";
  const fs::path model = root / "yolox_nano/yolox_nano.onnx";
  if (!fs::exists(model)) return std::nullopt;
  return model.string();
}

// Highest "person" score (objectness x class 0) of YOLOX-Nano on a 416x416 letterbox.
double BestPersonScore(cv::dnn::Net& net, const cv::Mat& image) {
  const int size = 416;
  const float scale =
      std::min(size / static_cast<float>(image.cols), size / static_cast<float>(image.rows));
  cv::Mat resized;
  cv::resize(image, resized, cv::Size(), scale, scale);
  cv::Mat canvas(size, size, CV_8UC3, cv::Scalar(114, 114, 114));
  resized.copyTo(canvas(cv::Rect(0, 0, resized.cols, resized.rows)));
  net.setInput(cv::dnn::blobFromImage(canvas, 1.0, cv::Size(), cv::Scalar(), false, false));
  const cv::Mat out = net.forward();
  const float* rows = reinterpret_cast<const float*>(out.data);
  double best = 0.0;
  for (int i = 0; i < out.size[1]; ++i)
    best = std::max(best, double{rows[i * 85 + 4] * rows[i * 85 + 5]});
  return best;
}

TEST(SyntheticDetectabilityTest, YoloxSeesTheSyntheticPeople) {
  const std::optional<std::string> model = YoloxModel();
  if (!model) GTEST_SKIP() << "yolox_nano.onnx not found (set STILLMAP_MODELS or ../shared/models)";
  testing::TempDir dir;
  SynthOptions options;
  options.scenario = "walking_xyz";
  options.frames = 240;
  WriteSyntheticSequence(dir / "seq", options);
  const Sequence sequence = Sequence::Open(dir / "seq", ResolveCamera(dir / "seq", {}));
  cv::dnn::Net net = cv::dnn::readNetFromONNX(*model);
  int visible = 0, detected = 0;
  for (size_t i = 0; i < sequence.frames().size(); i += 20) {
    const std::string name = fs::path(sequence.frames()[i].color_path).filename().string();
    const cv::Mat mask = cv::imread(dir / ("seq/masks/" + name), cv::IMREAD_UNCHANGED);
    if (cv::countNonZero(mask) < 0.05 * mask.total()) continue;  // nobody sizeably in view
    ++visible;
    detected += BestPersonScore(net, cv::imread(sequence.frames()[i].color_path)) > 0.3;
  }
  ASSERT_GE(visible, 5);
  EXPECT_GE(detected, 0.6 * visible) << detected << " of " << visible << " frames";
}

}  // namespace
}  // namespace stillmap
