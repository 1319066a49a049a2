// What the detectors share about their model files: reading class names, loading a network with
// errors that name the file, and checking that the file is the model expected.
#pragma once

#include <filesystem>
#include <map>
#include <opencv2/dnn.hpp>
#include <string>
#include <vector>

#include "stillmap/tracking/detector.h"

namespace stillmap::model_files {

// The non-empty lines of a class names file, trailing spaces cut. Throws InputError naming it.
std::vector<std::string> ReadNames(const std::filesystem::path& path);

// Where the right files come from, for the messages about wrong ones.
std::string ModelAdvice(const std::filesystem::path& dir);

// The network of an ONNX file, or of a Darknet configuration and weights. Throw InputError naming
// the file OpenCV cannot read.
cv::dnn::Net LoadOnnx(const std::filesystem::path& model, const std::filesystem::path& dir);
cv::dnn::Net LoadDarknet(const std::filesystem::path& cfg, const std::filesystem::path& weights,
                         const std::filesystem::path& dir);

// Runs the network once on `blob` and returns its (first) output, so that a model of another kind
// is named at load instead of failing inside OpenCV mid-run. Throws InputError naming `model`.
cv::Mat ForwardBlank(cv::dnn::Net* net, const cv::Mat& blob, const std::filesystem::path& model,
                     const std::filesystem::path& dir);

// The class count of the model's output against the names file's lines. Throws InputError.
void CheckNames(const std::vector<std::string>& names, int classes,
                const std::filesystem::path& names_path, const std::filesystem::path& dir);

// One class's candidate boxes (image pixels) and scores, before non-maximum suppression.
struct ClassBoxes {
  std::vector<cv::Rect2d> boxes;
  std::vector<float> scores;
};

// Class-aware non-maximum suppression (OpenCV 4.6 has no batched NMS: one call per class), the
// boxes clipped to the image, named and given their motion level; highest score first.
std::vector<Detection> SuppressPerClass(const std::map<int, ClassBoxes>& by_class,
                                        float score_threshold, float nms_threshold,
                                        const cv::Size& image,
                                        const std::vector<std::string>& names,
                                        const MotionLevelTable& levels);

}  // namespace stillmap::model_files
