// The build's mask stage, with its detector loaded before any output is written (so that a bad
// model is refused first).
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "stillmap/io/camera.h"
#include "stillmap/pipeline/build_result.h"
#include "stillmap/tracking/detector.h"
#include "stillmap/tracking/mask_stage.h"

namespace stillmap {

// What the mask stage reads of the request.
struct MaskSetupOptions {
  bool enabled = true;  // masking.enabled
  DynamicMaskOptions masking;
  std::string detector;    // run.detector
  std::string models_dir;  // run.models
  std::string models_found_by;
  MotionLevelTable levels;  // with detector.levels applied
  DetectorOptions detectors;
  std::string sequence_dir;     // its masks.txt, when it has one, gives ground-truth masks
  bool detector_thread = true;  // run.threads > 1
};

struct MaskSetup {
  std::unique_ptr<MaskStage> stage;
  MaskingFigures figures;             // without statistics (the frame loop adds them)
  std::vector<std::string> warnings;  // no model found for --detector auto
};

MaskSetup SetUpMasks(const MaskSetupOptions& options, const Camera& camera);

}  // namespace stillmap
