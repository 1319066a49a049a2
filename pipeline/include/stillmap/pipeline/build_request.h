// What `stillmap build` is asked to do: the sequence, the output folder and the configuration,
// whose run.* keys (poses, detector, models, threads) are the one copy of the run settings. A
// header of its own so that the build's steps take it without depending on the controller.
#pragma once

#include <optional>
#include <string>

#include "stillmap/pipeline/build_result.h"
#include "stillmap/pipeline/config.h"

namespace stillmap {

struct BuildRequest {
  std::string sequence_dir;
  std::string output_dir;
  BuildConfig config;  // config.run: poses, detector, models folder, threads
  // How config.run.models was found: "--models", "$STILLMAP_MODELS", ... (model_search.h); for
  // the report. Empty: given by the configuration (run.models).
  std::string models_found_by;
  bool show_progress = false;  // a progress line on stderr
  std::string command_line;    // as typed, for the report (empty: a library call)

  PoseSource poses() const {
    if (config.run.poses == "groundtruth") return PoseSource::kGroundTruth;
    if (config.run.poses == "tracking" || config.poses.use == "prior") return PoseSource::kTracking;
    return PoseSource::kGiven;
  }
  // Poses given as a file, tf:FRAME or odom:TOPIC (used as they are, or as the tracker's prior).
  std::optional<GivenPoseSource> given_poses() const {
    return ParseGivenPoseSource(config.run.poses, OptionKey(config, config.run.poses));
  }
  int threads() const { return config.run.threads; }
};

}  // namespace stillmap
