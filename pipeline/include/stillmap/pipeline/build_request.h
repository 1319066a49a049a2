// What `stillmap build` is asked to do: the sequence, the output folder, the configuration and
// how the run is carried out. A header of its own so that the build's steps take it without
// depending on the controller (build_pipeline.h).
#pragma once

#include <string>

#include "stillmap/pipeline/build_result.h"
#include "stillmap/pipeline/config.h"

namespace stillmap {

struct BuildRequest {
  std::string sequence_dir;
  std::string output_dir;
  BuildConfig config;
  PoseSource poses = PoseSource::kTracking;
  // auto (yolo-fastest, else yolox, whichever models_dir holds), none, yolo-fastest, yolox,
  // deeplab, both
  std::string detector = "auto";
  std::string models_dir;       // holds yolo_fastest_1.1/, yolox_nano/, deeplabv3_mnv2_voc/
  std::string models_found_by;  // how: "--models", "$STILLMAP_MODELS", ... (model_search.h)
  int threads = 2;  // 1: decode and map in one thread; >= 2: decode frames ahead (FrameReader)
  bool show_progress = false;  // a progress line on stderr
  std::string command_line;    // as typed, for the report (empty: a library call)
};

}  // namespace stillmap
