#include "yolox_net.h"

#include <fstream>
#include <iterator>

#include "onnx_graph.h"

namespace stillmap {
namespace {

// `got` is `expected` within 1e-4 of its largest value.
bool SameOutput(const cv::Mat& got, const cv::Mat& expected) {
  return got.size == expected.size && got.type() == expected.type() &&
         cv::norm(got, expected, cv::NORM_INF) <=
             1e-4 * std::max(1.0, cv::norm(expected, cv::NORM_INF));
}

// OpenCV's name for the layer of `stem`'s node: OpenCV 4.6 names the layer of ONNX node N
// "onnx_node!N"; others may use N itself or its output's name.
std::string LayerOf(cv::dnn::Net& net, const SliceStem& stem) {
  for (const std::string& name : net.getLayerNames()) {
    const size_t bang = name.rfind('!');
    const std::string node = bang == std::string::npos ? name : name.substr(bang + 1);
    if ((!stem.node.empty() && node == stem.node) || name == stem.output) return name;
  }
  return stem.output;
}

}  // namespace

YoloxNet::YoloxNet(cv::dnn::Net original, const std::string& model_path, int height, int width)
    : net_(original) {
  std::ifstream in(model_path, std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  // A random image, the same at every load; the original's output on it is the reference.
  cv::Mat image(height, width, CV_8UC3);
  cv::RNG(29).fill(image, cv::RNG::UNIFORM, 0, 256);
  const cv::Mat blob = cv::dnn::blobFromImage(image, 1.0, cv::Size(), cv::Scalar(), false, false);
  original.setInput(blob);
  const cv::Mat expected = original.forward().clone();
  // Both rewrites first (one graph to load and check when they hold, as they do for YOLOX-Nano),
  // then the fused activations alone.
  int fused_pairs = 0;
  const std::string fused_bytes = FuseSwish(bytes, &fused_pairs);
  SliceStem stem;
  const std::string cut_bytes = CutSliceStem(fused_bytes, height, width, &stem);
  std::vector<Plane> planes;
  if (!stem.output.empty()) {
    try {
      planes = PhaseOrder(&original, LayerOf(original, stem), blob);
    } catch (const cv::Exception&) {  // no such layer in OpenCV's net: the stem stays
    }
  }
  if (!planes.empty() && TryRewrite(cut_bytes, PhaseBlob(image, planes), expected)) {
    activations_fused_ = fused_pairs > 0;
    stem_planes_ = planes;
  } else if (fused_pairs > 0 && TryRewrite(fused_bytes, blob, expected)) {
    activations_fused_ = true;
  }
}

bool YoloxNet::TryRewrite(const std::string& bytes, const cv::Mat& input, const cv::Mat& expected) {
  try {
    cv::dnn::Net rewritten = cv::dnn::readNetFromONNX(bytes.data(), bytes.size());
    rewritten.setInput(input);
    if (!SameOutput(rewritten.forward(), expected)) return false;
    net_ = rewritten;
    return true;
  } catch (const cv::Exception&) {  // a rewrite OpenCV cannot run: the one before stays
    return false;
  }
}

std::vector<YoloxNet::Plane> YoloxNet::PhaseOrder(cv::dnn::Net* original,
                                                  const std::string& stem_layer,
                                                  const cv::Mat& probe) {
  original->setInput(probe);
  const cv::Mat stem = original->forward(stem_layer);
  const int rows = probe.size[2], columns = probe.size[3];
  if (stem.dims != 4 || stem.size[2] != rows / 2 || stem.size[3] != columns / 2) return {};
  std::vector<Plane> planes;
  for (int k = 0; k < stem.size[1]; ++k) {
    const cv::Mat channel(rows / 2, columns / 2, CV_32F,
                          const_cast<float*>(stem.ptr<float>(0, k)));  // a view
    bool found = false;
    for (int colour = 0; colour < 3 && !found; ++colour) {
      const cv::Mat whole(rows, columns, CV_32F, const_cast<float*>(probe.ptr<float>(0, colour)));
      for (int phase = 0; phase < 4 && !found; ++phase) {
        const Plane plane{colour, phase / 2, phase % 2};
        cv::Mat sampled(rows / 2, columns / 2, CV_32F);
        for (int v = 0; v < rows / 2; ++v) {
          for (int u = 0; u < columns / 2; ++u) {
            sampled.at<float>(v, u) = whole.at<float>(2 * v + plane[1], 2 * u + plane[2]);
          }
        }
        found = cv::norm(sampled, channel, cv::NORM_INF) == 0.0;
        if (found) planes.push_back(plane);
      }
    }
    if (!found) return {};
  }
  return planes;
}

cv::Mat YoloxNet::PhaseBlob(const cv::Mat& image, const std::vector<Plane>& planes) {
  const int rows = image.rows / 2, columns = image.cols / 2;
  const int shape[] = {1, static_cast<int>(planes.size()), rows, columns};
  cv::Mat blob(4, shape, CV_32F);
  for (size_t k = 0; k < planes.size(); ++k) {
    const auto [colour, row_phase, column_phase] = planes[k];
    float* out = blob.ptr<float>(0, static_cast<int>(k));
    for (int v = 0; v < rows; ++v) {
      const auto* pixel = image.ptr<cv::Vec3b>(2 * v + row_phase) + column_phase;
      for (ptrdiff_t u = 0; u < columns; ++u) *out++ = pixel[2 * u][colour];
    }
  }
  return blob;
}

cv::Mat YoloxNet::Forward(const cv::Mat& image) {
  CV_Assert(image.type() == CV_8UC3);
  net_.setInput(stem_planes_.empty()
                    ? cv::dnn::blobFromImage(image, 1.0, cv::Size(), cv::Scalar(), false, false)
                    : PhaseBlob(image, stem_planes_));
  return net_.forward();
}

}  // namespace stillmap
