// Where a build's poses came from and the frame they are in, as report.json says it.
#pragma once

#include <nlohmann/json.hpp>

#include "stillmap/pipeline/build_result.h"

namespace stillmap {

// "tracking", "groundtruth" or "given" (report.json's "poses").
const char* PoseSourceName(PoseSource poses);
// How the map was put in the ground truth's frame for its quality figures.
const char* AlignedBy(PoseSource poses);
// report.json's "map_frame".
nlohmann::json MapFrameJson(const MapFrameFigures& frame, PoseSource poses);
// report.json's "given_poses": the source, its use, chain and world, frames without a pose.
nlohmann::json GivenPosesJson(const GivenPoseFigures& given);
// report.json's "segments": each map segment's span, frames, keyframes, how it was joined (first,
// linked, not joined), and where it is (the map, or segments/<id>/).
nlohmann::json SegmentsJson(const std::vector<SegmentSummary>& segments);

}  // namespace stillmap
