// Synthetic scenarios written for the whole-build tests.
#pragma once

#include <cstddef>
#include <string>

#include "stillmap/synth/synthetic.h"

namespace stillmap {
namespace testing {

// Writes a synthetic sequence of `scenario`, `frames` frames long, to `sequence_dir`.
inline void WriteScenario(const std::string& sequence_dir, const std::string& scenario,
                          size_t frames) {
  SynthOptions options;
  options.scenario = scenario;
  options.frames = frames;
  WriteSyntheticSequence(sequence_dir, options);
}

}  // namespace testing
}  // namespace stillmap
