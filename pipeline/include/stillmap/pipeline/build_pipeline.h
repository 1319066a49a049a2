// `stillmap build`: a sequence in, every map output out. Library code, so that tests drive it
// exactly as the command line does. The steps live in pipeline/src, one file each: inputs, the
// frame reader, the ground-truth and tracked pose loops, the keyframe fuser, the map outputs,
// the evaluation and the report.
#pragma once

#include <string>
#include <vector>

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

// Every top-level name a build writes (folders end with '/'): a rerun replaces all of them, so
// that no file of an earlier run stays beside the new set.
const std::vector<std::string>& BuildOutputNames();

// Runs the whole build. Throws InputError for bad input or options (before anything is written),
// std::runtime_error when the run fails (an empty map among others). The outputs are staged aside
// and swapped in whole only when all exist (io/output_files.h); the output folder is locked.
BuildResult RunBuild(const BuildRequest& request);

}  // namespace stillmap
