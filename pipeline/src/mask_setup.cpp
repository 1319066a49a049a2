#include "mask_setup.h"

#include "stillmap/pipeline/model_search.h"

namespace stillmap {

MaskSetup SetUpMasks(const MaskSetupOptions& options, const Camera& camera) {
  MaskSetup setup;
  std::unique_ptr<Detector> detector;
  if (options.enabled) {
    detector =
        MakeDetector(options.detector, options.models_dir, options.levels, options.detectors);
    if (options.detector == "auto" && detector == nullptr && options.masking.semantics) {
      setup.warnings.push_back(
          (options.models_dir.empty() ? "no detector model in " + DescribeModelSearchPath()
                                      : "no detector model under '" + options.models_dir + "'") +
          ": moving objects are found by geometry only, and people who stand still stay in the "
          "map (scripts/fetch-models gets the model; or pass --models DIR holding "
          "yolo_fastest_1.1/ or yolox_nano/, "
          "or --detector none to silence this)");
    }
  }
  // One thread runs the same schedule (the detector when its result is due): the same masks.
  setup.stage = std::make_unique<MaskStage>(
      camera, options.masking, options.enabled, std::move(detector),
      options.masking.detector_in_background, options.sequence_dir, options.detector_thread);
  MaskingFigures& figures = setup.figures;
  figures.enabled = setup.stage->enabled();
  figures.detector = setup.stage->detector_name();
  figures.semantics = setup.stage->semantics();
  figures.options = setup.stage->options();
  if (setup.stage->semantics()) {
    figures.models_dir = options.models_dir;
    figures.models_found_by = options.models_found_by;
  }
  return setup;
}

}  // namespace stillmap
