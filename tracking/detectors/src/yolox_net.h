// YOLOX's network for OpenCV's DNN, its graph rewritten to run faster (onnx_graph.h) wherever the
// rewritten graph is checked, at load, to give the original's output.
#pragma once

#include <array>
#include <opencv2/core.hpp>
#include <opencv2/dnn.hpp>
#include <string>
#include <vector>

namespace stillmap {

class YoloxNet {
 public:
  // `original`: the model at `model_path` as OpenCV loaded it, for input images of `height` x
  // `width` pixels.
  YoloxNet(cv::dnn::Net original, const std::string& model_path, int height, int width);

  // The network's output for `image` (height x width, CV_8UC3, BGR 0..255 as YOLOX takes it).
  cv::Mat Forward(const cv::Mat& image);

  bool activations_fused() const { return activations_fused_; }
  bool stem_cut() const { return !stem_planes_.empty(); }

 private:
  // One channel of the sliced input: colour channel, row phase, column phase.
  using Plane = std::array<int, 3>;
  // The planes of `image`'s pixel phases, in the order of `planes`, as one 1 x n x h/2 x w/2 blob.
  static cv::Mat PhaseBlob(const cv::Mat& image, const std::vector<Plane>& planes);
  // The order in which `original` stacks the phases at its tensor `stem_output` (empty when its
  // channels are not plain phases of the input).
  // Runs `bytes` (a rewritten model) on `input`; when it gives `expected`, it becomes net_.
  bool TryRewrite(const std::string& bytes, const cv::Mat& input, const cv::Mat& expected);
  static std::vector<Plane> PhaseOrder(cv::dnn::Net* original, const std::string& stem_output,
                                       const cv::Mat& probe);

  cv::dnn::Net net_;
  bool activations_fused_ = false;
  std::vector<Plane> stem_planes_;  // empty: the net takes the whole image
};

}  // namespace stillmap
