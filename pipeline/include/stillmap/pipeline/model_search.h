// Where a build finds the detector's weights when --models (run.models) is not given: the
// documented search path, first folder that holds a model wins.
//   1. $STILLMAP_MODELS
//   2. the user's data folder: $XDG_DATA_HOME/stillmap/models (default ~/.local/share/...),
//      where scripts/fetch-models puts them
//   3. the install prefix's share folder: BIN/../share/stillmap/models, then the prefix the build
//      was configured with
//   4. beside the binary: BIN/models
//   5. ../shared/models (a developer's checkout beside the shared data)
// A folder holds a model when it has yolo_fastest_1.1/ (cfg, weights, coco.names), or
// yolox_nano/yolox_nano.onnx and coco.names, or deeplabv3_mnv2_voc/.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "stillmap/pipeline/config.h"

namespace stillmap {

struct ModelsFolder {
  std::string path;
  std::string found_by;  // "--models", "$STILLMAP_MODELS", "user data folder", ...
};

// The folders searched, in order (those whose variable is unset are left out).
std::vector<ModelsFolder> ModelSearchPath();

// The first folder of the search path that holds a model, if any.
std::optional<ModelsFolder> FindModels();

// What `build --detector auto` would run and from where, for `info` ("yolox (models in DIR,
// found through $STILLMAP_MODELS)").
std::string DescribeDefaultDetector();

// The models folder of a run: run->models when it is set (found by `given_by`), else the first
// folder of the search path that holds a model, unless run->detector is none. Returns how it was
// found ("" when there is none).
std::string ResolveModels(RunSettings* run, const std::string& given_by);

// One line naming the folders searched, for messages.
std::string DescribeModelSearchPath();

}  // namespace stillmap
