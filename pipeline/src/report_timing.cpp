#include "report_timing.h"

#include <algorithm>
#include <thread>
#include <vector>

#include "stillmap/io/cpu_usage.h"

namespace stillmap {
namespace {

using nlohmann::json;

double Median(std::vector<double> values) {
  if (values.empty()) return 0.0;
  const size_t middle = values.size() / 2;
  std::nth_element(values.begin(), values.begin() + static_cast<long>(middle), values.end());
  return values[middle];
}

json TimingJson(const std::vector<double>& values) {
  double total = 0.0;
  for (double value : values) total += value;
  return {{"median", Median(values)},
          {"mean", values.empty() ? 0.0 : total / static_cast<double>(values.size())},
          {"total", total}};
}

json TrackingTimingJson(const TrackingFigures& tracking) {
  const TrackerStatistics& t = tracking.statistics;
  return {
      {"extract", TimingJson(tracking.extract_ms)},
      {"match", TimingJson(tracking.match_ms)},
      {"pose", TimingJson(tracking.pose_ms)},
      {"keyframe", TimingJson(tracking.keyframe_ms)},
      {"track_total", TimingJson(tracking.total_ms)},
      {"local_bundle_adjustment",
       {{"runs", t.bundle_adjustments},
        {"mean", t.bundle_adjustments > 0
                     ? t.bundle_adjustment_ms / static_cast<double>(t.bundle_adjustments)
                     : 0.0},
        {"total", t.bundle_adjustment_ms}}},
      {"rgbd_odometry_total", t.rgbd_odometry_ms},
      {"place_recognition_and_loops_total", t.loop_ms},
      {"loop_pose_graph_total", t.loop_solve_ms},
      {"global_bundle_adjustment",
       {{"runs", t.global_bundle_adjustments}, {"total", t.global_bundle_adjustment_ms}}},
      {"refuse_map_total", tracking.refuse_ms},
      {"dense_refinement_total", tracking.dense_refinement ? tracking.dense_refinement->ms : 0.0},
      {"fuse_keyframes_total", tracking.fuse_ms}};
}

json TimingsJson(const BuildResult& result) {
  const StageTimings& t = result.timings;
  const MapperStatistics& stats = result.map.statistics;
  const double n = static_cast<double>(std::max<size_t>(stats.frames, 1));
  const double frames = static_cast<double>(result.frames.pairs_used - result.frames.without_pose);
  json timing = {
      {"load_wait_total", t.load_wait_ms},
      {"grid", t.grid_ms},
      {"mesh", t.mesh_ms},
      {"map_cleaning", t.map_cleaning_ms},
      {"back_projection_total", stats.back_projection_ms},
      {"voxel_total", stats.voxel_ms},
      {"octomap_total", stats.occupancy_ms},
      {"octomap_wait_total", stats.occupancy_wait_ms},
      {"fusion_wait_total", stats.wait_ms},
      {"write_outputs", t.write_ms},
      {"per_fused_frame",
       {{"back_projection", stats.back_projection_ms / n},
        {"voxel", stats.voxel_ms / n},
        {"octomap", stats.occupancy_ms / n},
        {"octomap_wait", stats.occupancy_wait_ms / n}}},
      {"per_frame", {{"load_wait", t.load_wait_ms / frames}, {"total", t.processing_ms / frames}}}};
  if (result.tracking) timing["tracking_ms"] = TrackingTimingJson(*result.tracking);
  if (result.masking.enabled) {
    // The flow check's image work runs ahead with the decoding (on the reading thread when
    // threads > 1), so it is not part of "mask".
    // A background detector's runs overlap the frame loop: only "detector_wait_total" is
    // part of it.
    const MaskingStatistics& s = result.masking.statistics;
    timing["masking_ms"] = {{"detector", TimingJson(s.detector_ms)},
                            {"detector_wait_total", s.detector_wait_ms},
                            {"mask", TimingJson(s.mask_ms)},
                            {"flow_ahead", TimingJson(t.flow_ms)}};
  }
  if (t.renders_ms) timing["renders"] = *t.renders_ms;
  return timing;
}

// Where the CPU time went, by thread (OpenCV's parallel loops run partly on its own workers,
// counted under "other"), and how busy the cores were: the next bottleneck at a glance.
json CpuJson(const BuildResult& result) {
  const StageTimings& t = result.timings;
  const MaskingStatistics& masking = result.masking.statistics;
  json stages = {{"reading_ahead", t.reader_cpu_ms / 1000.0},
                 {"frame_loop", t.frame_loop_cpu_ms / 1000.0},
                 {"frame_loop_masks", masking.mask_cpu_ms / 1000.0},
                 {"fusion_jobs", result.map.statistics.background_cpu_ms / 1000.0},
                 {"finishing_and_files", t.finish_cpu_ms / 1000.0}};
  double counted = t.reader_cpu_ms + t.frame_loop_cpu_ms + result.map.statistics.background_cpu_ms +
                   t.finish_cpu_ms;
  if (masking.detector_in_background) {  // otherwise inside the frame loop
    stages["detector"] = masking.detector_cpu_ms / 1000.0;
    counted += masking.detector_cpu_ms;
  }
  if (result.tracking && result.tracking->bundle_adjustment_thread) {
    const double worker = result.tracking->statistics.worker_cpu_ms;
    stages["bundle_adjustment_thread"] = worker / 1000.0;
    counted += worker;
  }
  stages["other"] = std::max(0.0, t.process_cpu_ms - counted) / 1000.0;
  const double cores = std::max(1u, std::thread::hardware_concurrency());
  const double wall_ms = std::max(result.wall_time_s * 1000.0, 1e-9);
  const double frames = static_cast<double>(std::max<size_t>(result.frames.pairs_used, 1));
  return {{"process_s", t.process_cpu_ms / 1000.0},
          {"per_frame_ms", t.process_cpu_ms / frames},
          {"cores", cores},
          {"cores_busy_mean", t.process_cpu_ms / wall_ms},
          {"share_of_cores", t.process_cpu_ms / (wall_ms * cores)},
          {"machine_core_busy", t.core_busy},
          {"allocator", MemoryAllocator()},
          {"by_thread_s", stages}};
}

// Where the memory went: the owners at the highest sample (code and libraries among them), what
// they leave unexplained there (stacks, the allocator's free lists, uncounted owners), and each
// one's largest.
json MemoryJson(const MemoryFigures& memory) {
  json at_peak = json::object(), largest = json::object();
  double counted = 0.0;
  for (const MemoryOwner& owner : memory.at_peak) {
    at_peak[owner.name] = owner.mib;
    counted += owner.mib;
  }
  for (const MemoryOwner& owner : memory.largest) largest[owner.name] = owner.mib;
  return {{"highest_mib", memory.peak_watched_mib},
          {"highest_phase", memory.peak_watched_phase},
          {"samples", memory.samples},
          {"highest_sample_mib", memory.peak_sample_mib},
          {"highest_sample_when", memory.peak_when},
          {"owners_at_highest_sample_mib", at_peak},
          {"not_counted_at_highest_sample_mib", std::max(0.0, memory.peak_sample_mib - counted)},
          {"owners_largest_mib", largest}};
}

}  // namespace

// Everything that depends on the machine and the moment rather than on the input and options,
// under one key, so that two runs compare equal once it is left out.
json RunTimingJson(const BuildResult& result) {
  json timing = {{"started_utc", result.started_utc},
                 {"wall_time_s", result.wall_time_s},
                 {"frames_per_second", result.frames_per_second},
                 {"peak_memory_mib", result.peak_memory_mib},
                 {"memory", MemoryJson(result.memory)},
                 {"stages_ms", TimingsJson(result)},
                 {"cpu", CpuJson(result)},
                 {"map_evaluation_s", result.evaluation.map_evaluation_s}};
  if (result.tracking) {
    const TrackerStatistics& t = result.tracking->statistics;
    const double median_track_ms = Median(result.tracking->total_ms);
    timing["tracking_frames_per_second_median"] =
        median_track_ms > 0 ? 1000.0 / median_track_ms : 0.0;
    timing["depth_self_calibration_ms_total"] = t.depth_calibration_ms;
    // A slow or busy machine shows as waits here, never as other poses.
    timing["bundle_adjustment_waits"] = t.bundle_adjustment_waits;
    timing["bundle_adjustment_wait_ms_total"] = t.bundle_adjustment_wait_ms;
    timing["loop_correction_waits"] = t.loop_waits;
    timing["loop_correction_wait_ms_total"] = t.loop_wait_ms;
  }
  return timing;
}

}  // namespace stillmap
