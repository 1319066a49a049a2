// `stillmap view OUT`: an interactive window (PCL's visualizer, VTK) on a build folder: the
// colored cloud, the OctoMap's occupied voxels, the trajectory and the fused keyframes.
#pragma once

#include <string>

namespace stillmap {

// The keys the window adds to PCL's own (h lists those).
constexpr const char* kViewWindowKeys =
    "v: occupied OctoMap voxels on/off; t: trajectory and keyframes on/off; m: the colored "
    "cloud on/off; r: reset the view; q: quit (PCL's keys, listed by h, work too)";

// Opens the window on OUT_DIR's map.ply, map.bt, trajectory.txt and keyframes.txt and returns
// when it is closed. With `screenshot_path` set, renders one frame, writes it there as PNG and
// returns without waiting (for tests under Xvfb). Throws InputError when OUT_DIR is not a build
// folder, std::runtime_error when no window can be opened (no display).
void RunViewWindow(const std::string& out_dir, const std::string& screenshot_path);

}  // namespace stillmap
