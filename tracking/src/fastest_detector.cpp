// Yolo-Fastest 1.1 (Darknet, COCO): a network about four times cheaper than YOLOX-Nano (issue 29).
// PROVENANCE.txt: blobFromImage(1/255, swapRB), two yolo layers whose rows are [cx, cy, w, h
// (normalised to the image), objectness, 80 class scores already multiplied by objectness].
#include <algorithm>
#include <cstdint>
#include <filesystem>
#include <map>
#include <opencv2/dnn.hpp>

#include "model_files.h"
#include "stillmap/io/error.h"
#include "stillmap/io/input_files.h"
#include "stillmap/tracking/detector.h"

namespace stillmap {
namespace {

namespace fs = std::filesystem;

using model_files::ClassBoxes;

// OpenCV reads a truncated or damaged Darknet weights file without a word (missing weights stay
// zero). The file must hold the header (16 or 20 bytes, by its version) and one float for every
// weight the configuration's layers hold (the yolo layers' anchors come from the configuration),
// and every weight must be finite and of a trained network's size: Yolo-Fastest's largest is
// 365, while a damaged exponent byte makes one 1e20 or more.
void CheckWeights(const cv::dnn::Net& net, const fs::path& weights, const fs::path& dir) {
  std::uintmax_t floats = 0;
  bool plausible = true;
  for (const std::string& name : net.getLayerNames()) {
    const cv::Ptr<cv::dnn::Layer> layer = net.getLayer(name);
    if (layer->type == "Region") continue;
    for (const cv::Mat& blob : layer->blobs) {
      floats += blob.total();
      plausible = plausible && cv::checkRange(blob, true, nullptr, -1e6, 1e6);
    }
  }
  const std::uintmax_t bytes = fs::file_size(weights);
  if (bytes != 16 + 4 * floats && bytes != 20 + 4 * floats) {
    throw InputError(weights.string() + ": " + std::to_string(bytes) +
                     " bytes, but its configuration needs " + std::to_string(floats) +
                     " weights (" + std::to_string(20 + 4 * floats) +
                     " bytes): the file is cut short or belongs to another model; " +
                     model_files::ModelAdvice(dir));
  }
  if (!plausible) {
    throw InputError(weights.string() + ": weights that are not finite or beyond 1e6: the file " +
                     "is damaged; " + model_files::ModelAdvice(dir));
  }
}

class FastestDetector : public Detector {
 public:
  FastestDetector(const std::string& models_dir, const MotionLevelTable& levels,
                  const FastestOptions& options)
      : levels_(levels), options_(options) {
    const fs::path dir = fs::path(models_dir) / "yolo_fastest_1.1";
    const fs::path cfg = dir / "yolo-fastest-1.1.cfg";
    const fs::path weights = dir / "yolo-fastest-1.1.weights";
    const std::string hint = " (pass --models DIR holding yolo_fastest_1.1/)";
    CheckInputFile(cfg.string(), "Yolo-Fastest configuration" + hint);
    CheckInputFile(weights.string(), "Yolo-Fastest weights" + hint);
    if (options.input_width % 32 != 0 || options.input_height % 32 != 0 ||
        options.input_width <= 0 || options.input_height <= 0) {
      throw InputError("the Yolo-Fastest input size must be a positive multiple of 32");
    }
    names_ = model_files::ReadNames(dir / "coco.names");
    net_ = model_files::LoadDarknet(cfg, weights, dir);
    CheckWeights(net_, weights, dir);
    // A blank image through the network: another model's output is named here, not mid-run.
    const cv::Mat blank(options.input_height, options.input_width, CV_8UC3, cv::Scalar::all(0));
    const cv::Mat out =
        model_files::ForwardBlank(&net_, cv::dnn::blobFromImage(blank, 1.0 / 255.0), weights, dir);
    if (out.dims != 2 || out.cols < 6) {
      throw InputError(weights.string() + ": the model's output is not a YOLO layer's (rows of " +
                       "box, objectness and class scores); " + model_files::ModelAdvice(dir));
    }
    model_files::CheckNames(names_, out.cols - 5, dir / "coco.names", dir);
    outputs_ = net_.getUnconnectedOutLayersNames();
  }

  std::string name() const override { return "yolo-fastest"; }

  std::vector<Detection> Detect(const cv::Mat& bgr) override {
    CV_Assert(bgr.type() == CV_8UC3);
    const cv::Size input(options_.input_width, options_.input_height);
    net_.setInput(cv::dnn::blobFromImage(bgr, 1.0 / 255.0, input, cv::Scalar(), true, false));
    std::vector<cv::Mat> outputs;
    net_.forward(outputs, outputs_);
    return model_files::SuppressPerClass(
        Candidates(outputs, bgr.size()), static_cast<float>(options_.score_threshold),
        static_cast<float>(options_.nms_threshold), bgr.size(), names_, levels_);
  }

 private:
  // Each row's best class, when its score reaches the threshold, as a box in image pixels.
  std::map<int, ClassBoxes> Candidates(const std::vector<cv::Mat>& outputs,
                                       const cv::Size& image) const {
    std::map<int, ClassBoxes> by_class;
    for (const cv::Mat& out : outputs) {
      for (int i = 0; i < out.rows; ++i) {
        const float* row = out.ptr<float>(i);
        const float* best = std::max_element(row + 5, row + out.cols);
        if (*best < options_.score_threshold) continue;
        const double w = row[2] * image.width, h = row[3] * image.height;
        ClassBoxes& found = by_class[static_cast<int>(best - (row + 5))];
        found.boxes.emplace_back(row[0] * image.width - w / 2, row[1] * image.height - h / 2, w, h);
        found.scores.push_back(*best);
      }
    }
    return by_class;
  }

  MotionLevelTable levels_;
  FastestOptions options_;
  cv::dnn::Net net_;
  std::vector<std::string> outputs_;
  std::vector<std::string> names_;
};

}  // namespace

std::unique_ptr<Detector> MakeFastestDetector(const std::string& models_dir,
                                              const MotionLevelTable& levels,
                                              const FastestOptions& options) {
  return std::make_unique<FastestDetector>(models_dir, levels, options);
}

}  // namespace stillmap
