// `stillmap build`: a sequence in, every map output out. Library code, so that tests drive it
// exactly as the command line does. The steps live in pipeline/src, one file each: inputs, the
// frame reader, the ground-truth and tracked pose loops, the keyframe fuser, the map outputs,
// the evaluation and the report.
#pragma once

#include <string>
#include <vector>

#include "stillmap/pipeline/build_request.h"
#include "stillmap/pipeline/build_result.h"

namespace stillmap {

// Runs the whole build. Throws InputError for bad input or options (before anything is written),
// std::runtime_error when the run fails (an empty map among others). The outputs are staged aside
// and swapped in whole only when all exist (io/output_files.h); the output folder is locked.
BuildResult RunBuild(const BuildRequest& request);

}  // namespace stillmap
