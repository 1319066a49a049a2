// Rendered test sequences for the tracking tests: noise-free frames of a synthetic scene whose
// rendering poses are the exact truth.
#pragma once

#include <string>

#include "stillmap/io/sequence.h"
#include "stillmap/viewer/synthetic.h"

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

}  // namespace stillmap::testing
