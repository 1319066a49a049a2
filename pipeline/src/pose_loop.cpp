#include <fmt/format.h>

#include "pose_loops.h"
#include "stillmap/io/cpu_usage.h"

namespace stillmap {

void SampleLoopMemory(const LoopStages& stages, double time,
                      std::vector<std::pair<std::string, size_t>> owners) {
  // The allocator's cached free blocks go back first: the reading is then of memory in use, and
  // the run does not carry them (floor seed 1, the frame loop's highest: 1631 -> 1434 MiB).
  ReleaseFreedMemory();
  const MapperMemory map = stages.mapper.memory();
  owners.emplace_back("voxel_cloud", map.voxel_cloud);
  owners.emplace_back("octomap", map.occupancy);
  owners.emplace_back("map_cleaning_views", map.views);
  owners.emplace_back("frames_read_ahead", stages.reader.ahead_bytes());
  stages.memory.Sample(fmt::format("frame loop, frame at {:.3f} s", time), owners);
}

LoopResult RunPoseLoop(const BuildInputs& inputs, const LoopOptions& options, MaskStage& masks,
                       Mapper& mapper, MemoryLedger& memory) {
  LoopResult result;
  ProgressLine progress("stillmap build", inputs.frame_indices.size(), options.show_progress);
  std::optional<FlowTracker> flow;
  if (options.flow) {
    // The mask stage resolved the corner count and the KLT window.
    flow.emplace(masks.options().flow_points, masks.options().flow);
  }
  const bool tracked = options.poses == PoseSource::kTracking;
  KnownPosePlan plan;
  std::vector<size_t> indices = inputs.frame_indices;
  if (!tracked) {
    plan = PlanKnownPoseFrames(inputs, options);
    indices.clear();
    for (const size_t k : plan.read) indices.push_back(inputs.frame_indices[k]);
  }
  FrameReader reader(inputs.sequence, std::move(indices), options.read_ahead, std::move(flow));
  const LoopStages stages{reader, masks, mapper, progress, memory};
  if (tracked) {
    result.posed = RunTrackedLoop(inputs, options, stages, &result);
  } else if (options.poses == PoseSource::kGiven && !options.FusesEveryFrame()) {
    result.posed = RunGivenPoseLoop(inputs, options, plan, stages, &result);
  } else {
    result.posed = RunGroundTruthLoop(inputs, options, plan, stages);
  }
  progress.Finish();
  result.reader_cpu_ms = reader.ahead_cpu_ms();
  result.load_wait_ms = reader.wait_ms();
  result.flow_ms = reader.flow_ms();
  const StreamChecks& checks = reader.checks();
  result.depth_median_m = checks.DepthQuantile(0.5);
  result.depth_95th_percentile_m = checks.DepthQuantile(0.95);
  result.frozen_colour = checks.frozen_colour_frames();
  // The streams' warnings, after the loop's own (tracking.planar_motion's).
  for (std::string& warning : checks.Warnings(inputs.camera.depth_factor)) {
    result.warnings.push_back(std::move(warning));
  }
  result.masking = masks.statistics();
  return result;
}

}  // namespace stillmap
