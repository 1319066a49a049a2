// Yolo-Fastest 1.1 (Darknet, COCO) as a detector: an experiment for issue 29 (a network about four
// times cheaper than YOLOX-Nano). PROVENANCE.txt: blobFromImage(1/255, swapRB), two yolo layers
// whose rows are [cx, cy, w, h (normalised), objectness, 80 class scores times objectness].
#include <algorithm>
#include <filesystem>
#include <fstream>
#include <map>
#include <opencv2/dnn.hpp>

#include "stillmap/io/input_files.h"
#include "stillmap/tracking/detector.h"

namespace stillmap {
namespace {

namespace fs = std::filesystem;

class FastestDetector : public Detector {
 public:
  FastestDetector(const std::string& models_dir, const MotionLevelTable& levels,
                  const YoloxOptions& options, int width, int height)
      : levels_(levels), options_(options), size_(width, height) {
    const fs::path dir = fs::path(models_dir) / "yolo_fastest_1.1";
    const fs::path cfg = dir / "yolo-fastest-1.1.cfg", weights = dir / "yolo-fastest-1.1.weights";
    CheckInputFile(cfg.string(), "Yolo-Fastest configuration");
    CheckInputFile(weights.string(), "Yolo-Fastest weights");
    net_ = cv::dnn::readNetFromDarknet(cfg.string(), weights.string());
    std::ifstream names(dir / "coco.names");
    for (std::string line; std::getline(names, line);) names_.push_back(line);
  }

  std::string name() const override { return "fastest"; }

  std::vector<Detection> Detect(const cv::Mat& bgr) override {
    net_.setInput(cv::dnn::blobFromImage(bgr, 1.0 / 255.0, size_, cv::Scalar(), true, false));
    std::vector<cv::Mat> outputs;
    net_.forward(outputs, net_.getUnconnectedOutLayersNames());
    std::map<int, std::pair<std::vector<cv::Rect2d>, std::vector<float>>> by_class;
    for (const cv::Mat& out : outputs) {
      for (int i = 0; i < out.rows; ++i) {
        const float* row = out.ptr<float>(i);
        const int best = static_cast<int>(std::max_element(row + 5, row + out.cols) - (row + 5));
        const float score = row[5 + best];
        if (score < options_.score_threshold) continue;
        const double w = row[2] * bgr.cols, h = row[3] * bgr.rows;
        auto& [boxes, scores] = by_class[best];
        boxes.emplace_back(row[0] * bgr.cols - w / 2, row[1] * bgr.rows - h / 2, w, h);
        scores.push_back(score);
      }
    }
    std::vector<Detection> detections;
    const cv::Rect2f image(0.0f, 0.0f, static_cast<float>(bgr.cols), static_cast<float>(bgr.rows));
    for (const auto& [c, found] : by_class) {
      std::vector<int> kept;
      cv::dnn::NMSBoxes(found.first, found.second, static_cast<float>(options_.score_threshold),
                        static_cast<float>(options_.nms_threshold), kept);
      for (int k : kept) {
        Detection detection;
        detection.box = cv::Rect2f(found.first[static_cast<size_t>(k)]) & image;
        if (detection.box.area() <= 0.0f) continue;
        detection.class_id = c;
        detection.name = c < static_cast<int>(names_.size()) ? names_[static_cast<size_t>(c)]
                                                             : std::to_string(c);
        detection.score = found.second[static_cast<size_t>(k)];
        detection.level = levels_.Level(detection.name);
        detections.push_back(detection);
      }
    }
    std::sort(detections.begin(), detections.end(),
              [](const Detection& a, const Detection& b) { return a.score > b.score; });
    return detections;
  }

 private:
  MotionLevelTable levels_;
  YoloxOptions options_;
  cv::Size size_;
  cv::dnn::Net net_;
  std::vector<std::string> names_;
};

}  // namespace

std::unique_ptr<Detector> MakeFastestDetector(const std::string& models_dir,
                                              const MotionLevelTable& levels,
                                              const YoloxOptions& options) {
  return std::make_unique<FastestDetector>(models_dir, levels, options, 320, 256);
}

}  // namespace stillmap
