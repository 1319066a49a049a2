// Rewrites of ONNX model bytes that OpenCV's DNN runs faster, with the same results.
#pragma once

#include <string>

namespace stillmap {

// YOLOX's SiLU activations, x * sigmoid(x), are exported as a Sigmoid node and a Mul node.
// OpenCV 4.6 runs them as two passes of their own after each convolution (38 of 84 ms of a
// 416x320 detection here, by Net::getPerfProfile); as one Swish node, which OpenCV fuses into the
// convolution before it, a detection takes 68 ms. Returns `model` (ONNX protobuf bytes) with each
// Sigmoid whose only consumer is a Mul of its input by its output replaced, with that Mul, by
// Swish; `fused` gets the count. Anything it cannot parse is returned unchanged (OpenCV then names
// the problem).
std::string FuseSwish(const std::string& model, int* fused);

// YOLOX's first step ("Focus") slices the input image into its four pixel phases (even and odd
// rows and columns) and concatenates them: eight Slice nodes and a Concat that OpenCV 4.6 runs in
// 11 of 68 ms. CutSliceStem returns `model` with those nodes removed and the Concat's output, of
// shape 1 x 12 x height/2 x width/2, as the graph's input, and names that Concat in `stem` (both
// names empty, and the model unchanged, when the graph does not start so: every node between the
// input and one Concat a Slice, nothing else reading them). The caller builds that input itself,
// in the channel order the original graph gives (checked against it at load).
struct SliceStem {
  std::string output;  // the Concat's output tensor
  std::string node;    // the Concat node's name (OpenCV's layer name)
};
std::string CutSliceStem(const std::string& model, int height, int width, SliceStem* stem);

}  // namespace stillmap
