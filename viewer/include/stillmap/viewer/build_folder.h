// A build folder read back for looking at it (`stillmap view`): the files `stillmap build` wrote.
#pragma once

#include <string>
#include <vector>

#include "stillmap/viewer/renders.h"

namespace stillmap {

// What a build folder holds for looking at it: map.ply, grid.yaml + grid.pgm when present,
// trajectory.txt and keyframes.txt, and the sequence's name from report.json. Throws InputError
// when OUT_DIR has no map.ply.
RenderInput ReadBuildFolder(const std::string& out_dir);

// `stillmap view OUT --png`: the renders of a build folder drawn again from its files (map.ply,
// grid.yaml + grid.pgm when present, trajectory.txt, keyframes.txt) into OUT/renders/. Returns
// the files written. Throws InputError when OUT is not a build folder.
std::vector<std::string> RenderBuildFolder(const std::string& out_dir);

}  // namespace stillmap
