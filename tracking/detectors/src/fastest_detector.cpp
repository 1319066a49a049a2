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
    CheckInputSizes(options);
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
    // Its own network: one Net reshaped between two input sizes reallocates its buffers each time.
    if (options.coarse_input_width > 0) coarse_net_ = model_files::LoadDarknet(cfg, weights, dir);
  }

  std::string name() const override { return "yolo-fastest"; }

  // The coarse pass adds the objects the first did not find: a coarse box that lies mostly on a
  // first-pass box of its class is dropped (the coarse boxes are looser).
  std::vector<Detection> Detect(const cv::Mat& bgr) override {
    CV_Assert(bgr.type() == CV_8UC3);
    const cv::Size fine(options_.input_width, options_.input_height);
    std::vector<Detection> detections = Pass(&net_, bgr, fine);
    if (options_.coarse_input_width == 0) return detections;
    const cv::Size coarse(options_.coarse_input_width, options_.coarse_input_height);
    const size_t first_pass = detections.size();
    for (Detection& extra : Pass(&coarse_net_, bgr, coarse)) {
      const auto covers = [&extra](const Detection& found) {
        return found.class_id == extra.class_id &&
               (found.box & extra.box).area() >=
                   0.5f * std::min(found.box.area(), extra.box.area());
      };
      if (std::none_of(detections.begin(), detections.begin() + first_pass, covers)) {
        extra.tentative = true;
        detections.push_back(std::move(extra));
      }
    }
    std::stable_sort(detections.begin(), detections.end(),
                     [](const Detection& a, const Detection& b) { return a.score > b.score; });
    return detections;
  }

 private:
  static void CheckInputSizes(const FastestOptions& options) {
    const auto valid = [](int size) { return size > 0 && size % 32 == 0; };
    if (!valid(options.input_width) || !valid(options.input_height)) {
      throw InputError("the Yolo-Fastest input size must be a positive multiple of 32");
    }
    const bool no_coarse = options.coarse_input_width == 0 && options.coarse_input_height == 0;
    if (!no_coarse && (!valid(options.coarse_input_width) || !valid(options.coarse_input_height))) {
      throw InputError(
          "the Yolo-Fastest coarse input size must be 0x0 or a positive multiple of 32");
    }
  }

  // The network on `bgr` scaled to `input`, after the per-class non-maximum suppression.
  std::vector<Detection> Pass(cv::dnn::Net* net, const cv::Mat& bgr, const cv::Size& input) {
    net->setInput(cv::dnn::blobFromImage(bgr, 1.0 / 255.0, input, cv::Scalar(), true, false));
    std::vector<cv::Mat> outputs;
    net->forward(outputs, outputs_);
    std::map<int, ClassBoxes> by_class;
    AddRows(outputs, bgr.size(), &by_class);
    return model_files::SuppressPerClass(by_class, static_cast<float>(options_.score_threshold),
                                         static_cast<float>(options_.nms_threshold), bgr.size(),
                                         names_, levels_);
  }

  // Each row's best class, when its score reaches the threshold, as a box in image pixels.
  void AddRows(const std::vector<cv::Mat>& outputs, const cv::Size& image,
               std::map<int, ClassBoxes>* by_class) const {
    for (const cv::Mat& out : outputs) {
      for (int i = 0; i < out.rows; ++i) {
        const float* row = out.ptr<float>(i);
        const float* best = std::max_element(row + 5, row + out.cols);
        if (*best < options_.score_threshold) continue;
        const double w = row[2] * image.width, h = row[3] * image.height;
        ClassBoxes& found = (*by_class)[static_cast<int>(best - (row + 5))];
        found.boxes.emplace_back(row[0] * image.width - w / 2, row[1] * image.height - h / 2, w, h);
        found.scores.push_back(*best);
      }
    }
  }

  MotionLevelTable levels_;
  FastestOptions options_;
  cv::dnn::Net net_;
  cv::dnn::Net coarse_net_;
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
