// Rendered test sequences for the tracking tests: frames of a synthetic scene whose rendering
// poses and people's masks are the exact truth.
#pragma once

#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <string>

#include "stillmap/io/sequence.h"
#include "stillmap/synth/synthetic.h"

namespace stillmap::testing {

// Renders `frames` noise-free frames (exact depth up to PNG steps, no color noise) of `scenario`
// into `dir` and opens the sequence.
inline Sequence RenderNoiseFreeSequence(const std::string& dir, const std::string& scenario,
                                        int frames) {
  SynthOptions options;
  options.scenario = scenario;
  options.frames = frames;
  options.depth_noise = false;
  options.color_noise = false;
  WriteSyntheticSequence(dir, options);
  return Sequence::Open(dir, ResolveCamera(dir, {}));
}

// Renders `frames` frames of `scenario` with the default sensor noise into `dir` and opens it.
inline Sequence RenderSequence(const std::string& dir, const std::string& scenario, int frames) {
  SynthOptions options;
  options.scenario = scenario;
  options.frames = frames;
  WriteSyntheticSequence(dir, options);
  return Sequence::Open(dir, ResolveCamera(dir, {}));
}

// The ground-truth mask of moving objects of frame i of a rendered sequence in `dir`: CV_8UC1,
// 255 on them.
inline cv::Mat MovingObjectMask(const std::string& dir, const Sequence& sequence, size_t i) {
  const std::string name =
      std::filesystem::path(sequence.frames()[i].color_path).filename().string();
  return cv::imread(dir + "/masks/" + name, cv::IMREAD_UNCHANGED) > 0;
}

}  // namespace stillmap::testing
