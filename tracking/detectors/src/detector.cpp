#include "stillmap/tracking/detector.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <map>
#include <opencv2/dnn.hpp>
#include <opencv2/imgproc.hpp>
#include <optional>

#include "model_files.h"
#include "stillmap/io/error.h"
#include "stillmap/io/file_list.h"
#include "stillmap/io/input_files.h"
#include "yolox_net.h"

namespace stillmap {

const char* MotionLevelName(MotionLevel level) {
  switch (level) {
    case MotionLevel::kHigh:
      return "high";
    case MotionLevel::kMedium:
      return "medium";
    case MotionLevel::kLow:
      return "low";
  }
  return "low";
}

MotionLevelTable MotionLevelTable::Default() {
  MotionLevelTable table;
  // High: people and animals (COCO and VOC spellings).
  for (const char* name : {"person", "bird", "cat", "dog", "horse", "sheep", "cow", "elephant",
                           "bear", "zebra", "giraffe"}) {
    table.levels_[name] = MotionLevel::kHigh;
  }
  // Medium: objects people easily move; paper 002 names chairs, books, keyboards and mice.
  for (const char* name : {"chair", "book", "keyboard", "mouse", "cup", "bottle", "wine glass",
                           "laptop", "cell phone", "remote", "backpack", "handbag", "suitcase",
                           "umbrella", "sports ball", "teddy bear", "bowl", "scissors"}) {
    table.levels_[name] = MotionLevel::kMedium;
  }
  return table;
}

MotionLevel MotionLevelTable::Level(const std::string& name) const {
  const auto it = levels_.find(name);
  return it == levels_.end() ? MotionLevel::kLow : it->second;
}

void MotionLevelTable::Set(const std::string& name, const std::string& level) {
  if (level == "high") {
    levels_[name] = MotionLevel::kHigh;
  } else if (level == "medium") {
    levels_[name] = MotionLevel::kMedium;
  } else if (level == "low") {
    levels_[name] = MotionLevel::kLow;
  } else {
    throw InputError("motion level of '" + name + "': '" + level +
                     "' is not one of high, medium, low");
  }
}

namespace {

namespace fs = std::filesystem;
using model_files::CheckNames;
using model_files::ForwardBlank;
using model_files::LoadOnnx;
using model_files::ModelAdvice;
using model_files::ReadNames;

// YOLOX decoding (PROVENANCE.txt): rows [cx cy w h obj cls...] on the grids of strides 8, 16
// and 32, raw; xy = (xy + grid) * stride, wh = exp(wh) * stride, score = obj * cls.
class YoloxDetector : public Detector {
 public:
  YoloxDetector(const std::string& models_dir, const MotionLevelTable& levels,
                const YoloxOptions& options)
      : levels_(levels), options_(options) {
    const fs::path dir = fs::path(models_dir) / "yolox_nano";
    const fs::path model = dir / "yolox_nano.onnx";
    CheckInputFile(model.string(), "YOLOX-Nano model (pass --models DIR holding yolox_nano/)");
    if (options.input_width % 32 != 0 || options.input_height % 32 != 0 ||
        options.input_width <= 0 || options.input_height <= 0) {
      throw InputError("the YOLOX input size must be a positive multiple of 32");
    }
    names_ = ReadNames(dir / "coco.names");
    cv::dnn::Net net = LoadOnnx(model, dir);  // as loaded, for the checks here
    for (int stride : {8, 16, 32}) {
      const int columns = options.input_width / stride, rows = options.input_height / stride;
      for (int y = 0; y < rows; ++y) {
        for (int x = 0; x < columns; ++x) grid_.push_back({x, y, stride});
      }
    }
    const int input_shape[] = {1, 3, options.input_height, options.input_width};
    const cv::Mat out =
        ForwardBlank(&net, cv::Mat(4, input_shape, CV_32F, cv::Scalar(114)), model, dir);
    if (out.dims != 3 || out.size[1] != static_cast<int>(grid_.size()) || out.size[2] < 6) {
      throw InputError(model.string() + ": the model's output is not YOLOX's (rows of box, " +
                       "objectness and class scores on the 8/16/32 grids); " + ModelAdvice(dir));
    }
    CheckNames(names_, out.size[2] - 5, dir / "coco.names", dir);
    // The same network rewritten to run faster, where it gives the same output (yolox_net.h).
    net_.emplace(net, model.string(), options.input_height, options.input_width);
  }

  std::string name() const override { return "yolox"; }

  std::vector<Detection> Detect(const cv::Mat& bgr) override {
    CV_Assert(bgr.type() == CV_8UC3);
    // Letterbox at the top left, pad 114, raw BGR 0..255.
    const float scale = std::min(static_cast<float>(options_.input_width) / bgr.cols,
                                 static_cast<float>(options_.input_height) / bgr.rows);
    cv::Mat resized;
    cv::resize(bgr, resized, cv::Size(), scale, scale, cv::INTER_LINEAR);
    cv::Mat canvas(options_.input_height, options_.input_width, CV_8UC3, cv::Scalar(114, 114, 114));
    resized.copyTo(canvas(
        cv::Rect(0, 0, std::min(resized.cols, canvas.cols), std::min(resized.rows, canvas.rows))));
    const cv::Mat out = net_->Forward(canvas);
    const int rows = out.size[1], width = out.size[2];
    const int classes = width - 5;
    if (out.dims != 3 || rows != static_cast<int>(grid_.size()) || classes < 1) {
      throw std::runtime_error("YOLOX output has an unexpected shape");
    }
    const float* data = out.ptr<float>();

    std::map<int, model_files::ClassBoxes> by_class;
    for (int i = 0; i < rows; ++i) {
      const float* row = data + static_cast<ptrdiff_t>(i) * width;
      const float objectness = row[4];
      if (objectness < options_.score_threshold) continue;
      const int best = static_cast<int>(std::max_element(row + 5, row + width) - (row + 5));
      const float score = objectness * row[5 + best];
      if (score < options_.score_threshold) continue;
      const GridCell& cell = grid_[static_cast<size_t>(i)];
      const float cx = (row[0] + static_cast<float>(cell.x)) * static_cast<float>(cell.stride);
      const float cy = (row[1] + static_cast<float>(cell.y)) * static_cast<float>(cell.stride);
      const float w = std::exp(row[2]) * static_cast<float>(cell.stride);
      const float h = std::exp(row[3]) * static_cast<float>(cell.stride);
      model_files::ClassBoxes& found = by_class[best];
      found.boxes.emplace_back((cx - w / 2) / scale, (cy - h / 2) / scale, w / scale, h / scale);
      found.scores.push_back(score);
    }
    return model_files::SuppressPerClass(by_class, static_cast<float>(options_.score_threshold),
                                         static_cast<float>(options_.nms_threshold), bgr.size(),
                                         names_, levels_);
  }

 private:
  struct GridCell {
    int x, y, stride;
  };
  MotionLevelTable levels_;
  YoloxOptions options_;
  std::vector<std::string> names_;
  std::optional<YoloxNet> net_;  // set by the constructor
  std::vector<GridCell> grid_;
};

// DeepLab decoding (PROVENANCE.txt): NHWC 1x257x257x3 RGB input scaled to [-1, 1], NHWC
// 1x257x257x21 logits out; argmax per pixel, resized with nearest neighbour to the image.
class DeeplabDetector : public Detector {
 public:
  static constexpr int kInputSize = 257;  // fixed: pooling and upsampling scales are baked in

  DeeplabDetector(const std::string& models_dir, const MotionLevelTable& levels,
                  const DeeplabOptions& options)
      : levels_(levels), options_(options) {
    const fs::path dir = fs::path(models_dir) / "deeplabv3_mnv2_voc";
    const fs::path model = dir / "deeplab_v3_mnv2_voc_opencv46.onnx";
    CheckInputFile(model.string(),
                   "DeepLabV3 model (pass --models DIR holding deeplabv3_mnv2_voc/)");
    names_ = ReadNames(dir / "voc.names");
    net_ = LoadOnnx(model, dir);
    const int input_shape[] = {1, kInputSize, kInputSize, 3};
    const cv::Mat out =
        ForwardBlank(&net_, cv::Mat(4, input_shape, CV_32F, cv::Scalar(0)), model, dir);
    if (out.dims != 4 || out.size[1] != kInputSize || out.size[2] != kInputSize ||
        out.size[3] < 2) {
      throw InputError(model.string() + ": the model's output is not DeepLab's (per-pixel " +
                       "class scores, 257x257); " + ModelAdvice(dir));
    }
    CheckNames(names_, out.size[3], dir / "voc.names", dir);
  }

  std::string name() const override { return "deeplab"; }

  std::vector<Detection> Detect(const cv::Mat& bgr) override {
    CV_Assert(bgr.type() == CV_8UC3);
    cv::Mat resized, rgb, scaled;
    cv::resize(bgr, resized, cv::Size(kInputSize, kInputSize), 0, 0, cv::INTER_LINEAR);
    cv::cvtColor(resized, rgb, cv::COLOR_BGR2RGB);
    rgb.convertTo(scaled, CV_32FC3, 1.0 / 127.5, -1.0);
    // NHWC: the interleaved image is already laid out as 1x257x257x3.
    const int input_shape[] = {1, kInputSize, kInputSize, 3};
    cv::Mat blob(4, input_shape, CV_32F, scaled.data);
    net_.setInput(blob);
    const cv::Mat out = net_.forward();
    const int classes = out.dims == 4 ? out.size[3] : 0;
    if (out.dims != 4 || out.size[1] != kInputSize || out.size[2] != kInputSize || classes < 2) {
      throw std::runtime_error("DeepLab output has an unexpected shape");
    }
    cv::Mat labels(kInputSize, kInputSize, CV_8UC1);
    const float* data = out.ptr<float>();
    for (int i = 0; i < kInputSize * kInputSize; ++i) {
      const float* logits = data + static_cast<ptrdiff_t>(i) * classes;
      labels.data[i] =
          static_cast<std::uint8_t>(std::max_element(logits, logits + classes) - logits);
    }
    cv::Mat full;
    cv::resize(labels, full, bgr.size(), 0, 0, cv::INTER_NEAREST);

    std::vector<Detection> detections;
    const double min_area = options_.min_segment_share * bgr.total();
    cv::Mat class_mask, components, stats, centroids;
    for (int c = 1; c < classes; ++c) {
      class_mask = full == c;
      if (cv::countNonZero(class_mask) < min_area) continue;
      const int count =
          cv::connectedComponentsWithStats(class_mask, components, stats, centroids, 8, CV_32S);
      for (int k = 1; k < count; ++k) {
        if (stats.at<int>(k, cv::CC_STAT_AREA) < min_area) continue;
        const cv::Rect box(stats.at<int>(k, cv::CC_STAT_LEFT), stats.at<int>(k, cv::CC_STAT_TOP),
                           stats.at<int>(k, cv::CC_STAT_WIDTH),
                           stats.at<int>(k, cv::CC_STAT_HEIGHT));
        Detection detection;
        detection.box = cv::Rect2f(box);
        detection.class_id = c;
        detection.name = c < static_cast<int>(names_.size()) ? names_[static_cast<size_t>(c)]
                                                             : std::to_string(c);
        detection.score = 1.0f;
        detection.level = levels_.Level(detection.name);
        detection.mask = components(box) == k;
        detections.push_back(std::move(detection));
      }
    }
    return detections;
  }

 private:
  MotionLevelTable levels_;
  DeeplabOptions options_;
  std::vector<std::string> names_;
  cv::dnn::Net net_;
};

class CombinedDetector : public Detector {
 public:
  CombinedDetector(std::unique_ptr<Detector> first, std::unique_ptr<Detector> second)
      : first_(std::move(first)), second_(std::move(second)) {}
  std::string name() const override { return "both"; }
  std::vector<Detection> Detect(const cv::Mat& bgr) override {
    std::vector<Detection> detections = first_->Detect(bgr);
    std::vector<Detection> more = second_->Detect(bgr);
    detections.insert(detections.end(), std::make_move_iterator(more.begin()),
                      std::make_move_iterator(more.end()));
    return detections;
  }

 private:
  std::unique_ptr<Detector> first_;
  std::unique_ptr<Detector> second_;
};

}  // namespace

std::unique_ptr<Detector> MakeDeeplabDetector(const std::string& models_dir,
                                              const MotionLevelTable& levels,
                                              const DeeplabOptions& options) {
  return std::make_unique<DeeplabDetector>(models_dir, levels, options);
}

std::unique_ptr<Detector> MakeCombinedDetector(std::unique_ptr<Detector> first,
                                               std::unique_ptr<Detector> second) {
  return std::make_unique<CombinedDetector>(std::move(first), std::move(second));
}

std::unique_ptr<Detector> MakeYoloxDetector(const std::string& models_dir,
                                            const MotionLevelTable& levels,
                                            const YoloxOptions& options) {
  return std::make_unique<YoloxDetector>(models_dir, levels, options);
}

bool HoldsFastest(const std::string& models_dir) {
  std::error_code error;
  const fs::path dir = fs::path(models_dir) / "yolo_fastest_1.1";
  return fs::is_regular_file(dir / "yolo-fastest-1.1.cfg", error) &&
         fs::is_regular_file(dir / "yolo-fastest-1.1.weights", error) &&
         fs::is_regular_file(dir / "coco.names", error);
}

bool HoldsYolox(const std::string& models_dir) {
  std::error_code error;
  const fs::path dir = fs::path(models_dir) / "yolox_nano";
  return fs::is_regular_file(dir / "yolox_nano.onnx", error) &&
         fs::is_regular_file(dir / "coco.names", error);
}

std::string ResolveDetectorName(const std::string& name, const std::string& models_dir) {
  if (name != "auto") return name;
  if (models_dir.empty()) return "none";
  const bool fastest = HoldsFastest(models_dir), yolox = HoldsYolox(models_dir);
  if (fastest && yolox) return "yolo-fastest+yolox";
  if (fastest) return "yolo-fastest";
  return yolox ? "yolox" : "none";
}

std::unique_ptr<Detector> MakeDetector(const std::string& name, const std::string& models_dir,
                                       const MotionLevelTable& levels,
                                       const DetectorOptions& options) {
  if (name == "none" || name.empty()) return nullptr;
  if (name == "auto") {
    return MakeDetector(ResolveDetectorName(name, models_dir), models_dir, levels, options);
  }
  if (models_dir.empty()) {
    throw InputError("--detector " + name +
                     " needs the models and none were found: run scripts/fetch-models, or pass "
                     "--models DIR (the folder holding yolo_fastest_1.1/, yolox_nano/ and "
                     "deeplabv3_mnv2_voc/) or set STILLMAP_MODELS");
  }
  if (name == "yolo-fastest") return MakeFastestDetector(models_dir, levels, options.fastest);
  if (name == "yolox") return MakeYoloxDetector(models_dir, levels, options.yolox);
  if (name == "yolo-fastest+yolox") {
    return MakeSecondOpinionDetector(MakeFastestDetector(models_dir, levels, options.fastest),
                                     MakeYoloxDetector(models_dir, levels, options.yolox));
  }
  if (name == "deeplab") return MakeDeeplabDetector(models_dir, levels, options.deeplab);
  if (name == "both") {
    return MakeCombinedDetector(MakeYoloxDetector(models_dir, levels, options.yolox),
                                MakeDeeplabDetector(models_dir, levels, options.deeplab));
  }
  throw InputError(
      "--detector " + name +
      ": expected auto, none, yolo-fastest, yolox, yolo-fastest+yolox, deeplab or both");
}

}  // namespace stillmap
