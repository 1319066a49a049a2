// The run report's tracking section: the tracker's counts, its losses and what undid them, loops
// and the depth self-calibration.
#pragma once

#include <nlohmann/json.hpp>

#include "stillmap/pipeline/build_result.h"
#include "stillmap/tracking/tracker_options.h"

namespace stillmap {

// The "tracking" key of report.json.
nlohmann::json TrackingJson(const TrackingFigures& tracking, const TrackerOptions& options);

}  // namespace stillmap
