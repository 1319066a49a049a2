// The run report's timing section: wall-clock stage times, CPU time by thread and core use.
#pragma once

#include <nlohmann/json.hpp>

#include "stillmap/pipeline/build_result.h"

namespace stillmap {

// Everything in report.json that depends on the machine and the moment (the "timing" key).
nlohmann::json RunTimingJson(const BuildResult& result);

}  // namespace stillmap
