// session.bin of a build: the fused keyframes, moved into the map frame, for `stillmap merge`.
#pragma once

#include <string>
#include <vector>

#include "build_inputs.h"
#include "stillmap/io/session_keyframes.h"
#include "stillmap/pipeline/build_result.h"

namespace stillmap {

// Writes `keyframes` (poses in the poses' frame, depth PNGs in steps of depth_unit_m) to `path`
// with their poses and the floor in the outputs' frame `frame`.
void WriteSessionFile(SessionKeyframeList keyframes, double depth_unit_m,
                      const MapFrameFigures& frame, const BuildInputs& inputs,
                      const std::string& sequence, const std::string& path);

}  // namespace stillmap
