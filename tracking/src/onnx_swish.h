// SiLU activations of an ONNX model fused into single Swish nodes, for OpenCV's DNN.
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

}  // namespace stillmap
