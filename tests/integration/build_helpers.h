// What the whole-build tests share.
#pragma once

#include <string>
#include <vector>

#include "stillmap/pipeline/build_pipeline.h"
#include "test_util.h"

namespace stillmap {
namespace testing {

// Every file a default build writes.
inline constexpr const char* kOutputs[] = {"map.ply",
                                           "map.pcd",
                                           "map.bt",
                                           "map.ot",
                                           "trajectory.txt",
                                           "keyframes.txt",
                                           "grid.pgm",
                                           "grid.yaml",
                                           "mesh.glb",
                                           "report.json",
                                           "report.html",
                                           "config.yaml",
                                           "renders/grid_top.png",
                                           "renders/cloud_view_1.png",
                                           "renders/cloud_view_2.png"};

// Tracks a sequence with the bundle adjustment inline (the figure does not depend on thread
// timing) and no OctoMap (not under test), plus `settings`; the outputs go to `output_dir`, or to
// a temporary folder when it is empty.
inline BuildResult TrackRepeatably(const std::string& sequence,
                                   const std::vector<std::string>& settings = {},
                                   const std::string& output_dir = {}) {
  testing::TempDir dir;
  BuildRequest request;
  request.sequence_dir = sequence;
  request.output_dir = output_dir.empty() ? dir / "out" : output_dir;
  ApplySetArgument(&request.config, "tracking.background_bundle_adjustment=false");
  ApplySetArgument(&request.config, "octomap.enabled=false");
  for (const std::string& setting : settings) ApplySetArgument(&request.config, setting);
  return RunBuild(request);
}

}  // namespace testing
}  // namespace stillmap
