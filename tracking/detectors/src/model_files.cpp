#include "model_files.h"

#include <algorithm>

#include "stillmap/io/error.h"
#include "stillmap/io/file_list.h"

namespace stillmap::model_files {

namespace fs = std::filesystem;

std::vector<std::string> ReadNames(const fs::path& path) {
  std::vector<std::string> names;
  for (std::string line : ReadTextLines(path.string(), "class names file")) {
    while (!line.empty() && line.back() == ' ') line.pop_back();
    if (!line.empty()) names.push_back(line);
  }
  return names;
}

std::string ModelAdvice(const fs::path& dir) {
  return "the right files are in ../shared/models/" + dir.filename().string() +
         "/ (see its PROVENANCE.txt); pass that folder's parent with --models";
}

cv::dnn::Net LoadOnnx(const fs::path& model, const fs::path& dir) {
  try {
    return cv::dnn::readNetFromONNX(model.string());
  } catch (const cv::Exception& e) {
    throw InputError(model.string() + ": OpenCV cannot read this file as an ONNX model (" +
                     Quoted(e.err, 120) + "); it is damaged or another kind of file; " +
                     ModelAdvice(dir));
  }
}

cv::dnn::Net LoadDarknet(const fs::path& cfg, const fs::path& weights, const fs::path& dir) {
  try {
    return cv::dnn::readNetFromDarknet(cfg.string(), weights.string());
  } catch (const cv::Exception& e) {
    throw InputError(cfg.string() + " and " + weights.string() +
                     ": OpenCV cannot read them as a Darknet model (" + Quoted(e.err, 120) +
                     "); they are damaged or other kinds of file; " + ModelAdvice(dir));
  }
}

cv::Mat ForwardBlank(cv::dnn::Net* net, const cv::Mat& blob, const fs::path& model,
                     const fs::path& dir) {
  try {
    net->setInput(blob);
    return net->forward().clone();
  } catch (const cv::Exception&) {
    throw InputError(model.string() + ": the model does not take the input " +
                     dir.filename().string() +
                     " needs (is it another model, or the files swapped?); " + ModelAdvice(dir));
  }
}

void CheckNames(const std::vector<std::string>& names, int classes, const fs::path& names_path,
                const fs::path& dir) {
  if (static_cast<int>(names.size()) != classes) {
    throw InputError(names_path.string() + ": holds " + std::to_string(names.size()) +
                     " class names but the model gives " + std::to_string(classes) +
                     " classes (one name per line, in the model's order); " + ModelAdvice(dir));
  }
}

std::vector<Detection> SuppressPerClass(const std::map<int, ClassBoxes>& by_class,
                                        float score_threshold, float nms_threshold,
                                        const cv::Size& image,
                                        const std::vector<std::string>& names,
                                        const MotionLevelTable& levels) {
  std::vector<Detection> detections;
  const cv::Rect2f frame(0.0f, 0.0f, static_cast<float>(image.width),
                         static_cast<float>(image.height));
  for (const auto& [c, found] : by_class) {
    std::vector<int> kept;
    cv::dnn::NMSBoxes(found.boxes, found.scores, score_threshold, nms_threshold, kept);
    for (const int k : kept) {
      Detection detection;
      detection.box = cv::Rect2f(found.boxes[static_cast<size_t>(k)]) & frame;
      if (detection.box.area() <= 0.0f) continue;
      detection.class_id = c;
      detection.name =
          c < static_cast<int>(names.size()) ? names[static_cast<size_t>(c)] : std::to_string(c);
      detection.score = found.scores[static_cast<size_t>(k)];
      detection.level = levels.Level(detection.name);
      detections.push_back(detection);
    }
  }
  std::sort(detections.begin(), detections.end(),
            [](const Detection& a, const Detection& b) { return a.score > b.score; });
  return detections;
}

}  // namespace stillmap::model_files
