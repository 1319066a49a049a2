#include "stillmap/pipeline/build_pipeline.h"

#include <fmt/chrono.h>
#include <sys/stat.h>

#include <algorithm>
#include <chrono>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <opencv2/core.hpp>
#include <thread>

#include "build_evaluation.h"
#include "build_inputs.h"
#include "frame_reader.h"
#include "map_finish.h"
#include "map_outputs.h"
#include "mask_setup.h"
#include "memory_ledger.h"
#include "merge_links.h"
#include "pose_loops.h"
#include "segment_output.h"
#include "stillmap/io/cpu_usage.h"
#include "stillmap/io/error.h"
#include "stillmap/io/output_files.h"
#include "stillmap/io/timing.h"
#include "stillmap/pipeline/model_search.h"
#include "stillmap/pipeline/progress.h"
#include "stillmap/pipeline/report.h"
#include "stillmap/pipeline/report_html.h"

namespace stillmap {
namespace {

namespace fs = std::filesystem;

using Clock = std::chrono::steady_clock;

// The output folder may not be the sequence folder or lie inside it: a rerun replaces the whole
// output set, and the next build would read the outputs as part of the sequence.
void CheckOutputOutsideSequence(const BuildRequest& request) {
  std::error_code error;
  auto resolved = [&error](const std::string& path) {  // absolute, no '.', '..' or trailing '/'
    fs::path p = fs::weakly_canonical(path, error).lexically_normal();
    return p.has_filename() ? p : p.parent_path();
  };
  const fs::path sequence = resolved(request.sequence_dir);
  const fs::path output = resolved(request.output_dir);
  if (error || sequence.empty()) return;  // the inputs' own checks name the problem
  const auto [at_sequence_end, at_output] =
      std::mismatch(sequence.begin(), sequence.end(), output.begin(), output.end());
  bool same = at_sequence_end == sequence.end() && at_output == output.end();
  bool inside = at_sequence_end == sequence.end() && !same;
  // The same folder reached by another path (a bind mount, a hard-linked mount point): compare
  // device and inode of the output folder and each existing folder above it with the sequence's.
  struct stat sequence_info {};
  if (!inside && !same && ::stat(sequence.c_str(), &sequence_info) == 0) {
    for (fs::path at = output; !at.empty(); at = at.parent_path()) {
      struct stat info {};
      if (::stat(at.c_str(), &info) == 0 && info.st_dev == sequence_info.st_dev &&
          info.st_ino == sequence_info.st_ino) {
        (at == output ? same : inside) = true;
        break;
      }
      if (at == at.root_path()) break;
    }
  }
  if (same || inside) {
    throw InputError("-o " + request.output_dir + ": the output folder is " +
                     (same ? "the sequence folder" : "inside the sequence folder") + " " +
                     request.sequence_dir +
                     " (perhaps through a mount or link); write the outputs elsewhere");
  }
}

void CheckRequest(const BuildRequest& request) {
  request.config.Validate();
  if (request.threads() < 1) throw InputError("--threads must be at least 1");
  CheckOutputOutsideSequence(request);
  // OpenCV's own parallel loops (the depth check, KLT, ORB's pyramid) use as many threads, at
  // most one per core: TBB, OpenCV's backend, warns on stderr about more, even under --quiet.
  const int cores = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
#if defined(__SANITIZE_THREAD__)
  // ThreadSanitizer cannot see TBB's hand-overs (Debian's TBB is not instrumented) and reports
  // every parallel_for_ body as racing with its caller: OpenCV's loops run on the calling thread
  // under TSan, and what it checks are stillmap's own threads (scripts/tsan.sh).
  cv::setNumThreads(1);
  static_cast<void>(cores);
#else
  cv::setNumThreads(std::min(request.threads(), cores));
#endif
}

// The slices of the request each step reads.
InputOptions InputOptionsOf(const BuildRequest& request) {
  const BuildConfig& config = request.config;
  const MapperOptions& mapping = config.mapping;
  return {request.sequence_dir,   request.poses(),
          request.given_poses(),  config.poses,
          config.map.frame,       config.camera,
          config.sequence,        config.first_frame,
          config.max_frames,      mapping.back_projection.max_depth,
          mapping.Extent(),       mapping.occupancy.resolution,
          mapping.voxel.leaf_size};
}

MaskSetupOptions MaskOptionsOf(const BuildRequest& request) {
  const BuildConfig& config = request.config;
  MaskSetupOptions options;
  options.enabled = config.masking_enabled;
  options.masking = config.masking;
  options.detector = config.run.detector;
  options.models_dir = config.run.models;
  options.models_found_by = request.models_found_by.empty() ? OptionKey(config, config.run.models)
                                                            : request.models_found_by;
  if (config.masking_enabled) options.levels = MotionLevels(config);  // checks detector.levels
  options.detectors = {config.fastest, config.yolox, config.deeplab};
  options.sequence_dir = request.sequence_dir;
  options.detector_thread = request.threads() > 1;
  return options;
}

LoopOptions LoopOptionsOf(const BuildRequest& request) {
  const BuildConfig& config = request.config;
  LoopOptions options;
  options.poses = request.poses();
  options.tracking = config.tracking;
  if (request.threads() == 1) options.tracking.local_map.background_bundle_adjustment = false;
  const BackProjectionOptions& depth = config.mapping.back_projection;
  options.fuser = {config.tracking.loops.loop_closure,
                   config.session_record,
                   config.map_recheck,
                   config.masking,
                   config.selection,
                   depth.min_depth,
                   depth.max_depth};
  options.refinement = config.final_poses;
  options.smoothing = config.trajectory_smoothing;
  options.segments.place = config.tracking.loops.place;
  options.segments.place_candidates = config.merge.place_candidates;
  options.segments.place_min_votes = config.merge.place_min_votes;
  options.segments.links = LinkOptions(config.merge);
  options.segments.pose_graph = config.tracking.loops.pose_graph;
  options.segments.link_weight = config.merge.link_weight;
  options.segments.full_weight_inliers = config.tracking.loops.pose_graph_full_weight_inliers;
  options.segments.min_weight = config.tracking.loops.pose_graph_min_weight;
  options.groundtruth_reference_interval = config.groundtruth_reference_interval;
  if (options.poses == PoseSource::kGiven) {
    options.keyframe_distance_m = config.poses.keyframe_distance_m;
    options.keyframe_angle_deg = config.poses.keyframe_angle_deg;
    options.given_session = config.session_record;
  }
  options.flow = config.masking_enabled && config.masking.TracksFlow();
  options.read_ahead = request.threads() > 1;
  options.parallel = request.threads() > 1;
  options.show_progress = request.show_progress;
  return options;
}

MapFinishOptions MapFinishOptionsOf(const BuildRequest& request) {
  const BuildConfig& config = request.config;
  return {config.mapping,
          config.grid,
          {config.map.frame, request.poses(), config.sequence.max_groundtruth_gap},
          request.threads() > 1};
}

MapFileOptions MapFileOptionsOf(const BuildRequest& request) {
  return {request.config.mesh, request.config.mapping.voxel.leaf_size, request.threads() > 1};
}

EvaluationOptions EvaluationOptionsOf(const BuildRequest& request) {
  const BuildConfig& config = request.config;
  return {request.sequence_dir, request.poses(), config.sequence.max_groundtruth_gap, config.ate,
          config.rpe};
}

void Append(std::vector<std::string> from, std::vector<std::string>* to) {
  for (std::string& line : from) to->push_back(std::move(line));
}

// What the finished map's owners hold [bytes] (memory_ledger.h); `cloud` its points, once taken,
// and the keyframes for session.bin until it is written.
std::vector<std::pair<std::string, size_t>> FinishingOwners(const FinishedMap& map,
                                                            const std::vector<VoxelPoint>& cloud,
                                                            const PosedFrames& posed) {
  size_t views = 0;
  for (const KeyframeView& view : map.views) {
    views += view.MemoryBytes();
  }
  return {{"voxel_cloud", map.cloud.MemoryBytes()},
          {"octomap", map.occupancy ? map.occupancy->MemoryBytes() : 0},
          {"map_cleaning_views", views},
          {"cloud_points", cloud.capacity() * sizeof(VoxelPoint)},
          {"keyframe_copies", posed.session_keyframes.MemoryBytes()}};
}

// The frame loop's figures into the result.
void TakeLoopFigures(LoopResult loop, BuildResult* result) {
  result->tracking = std::move(loop.tracking);
  result->selection = loop.selection;
  result->segments = std::move(loop.segments);
  result->segment_links = loop.segment_links;
  result->masking.statistics = loop.masking;
  result->frames.depth_median_m = loop.depth_median_m;
  result->frames.depth_95th_percentile_m = loop.depth_95th_percentile_m;
  result->frames.frozen_colour = loop.frozen_colour;
  result->timings.reader_cpu_ms = loop.reader_cpu_ms;
  result->timings.load_wait_ms = loop.load_wait_ms;
  result->timings.flow_ms = std::move(loop.flow_ms);
  Append(std::move(loop.warnings), &result->warnings);
}

// An earlier run's outputs restored, and files stillmap did not write, said as warnings.
void AddOutputFolderWarnings(const OutputSet& outputs, std::vector<std::string>* warnings) {
  if (!outputs.recovery_note().empty()) warnings->push_back(outputs.recovery_note());
  const std::vector<std::string> foreign = outputs.ForeignNames();
  if (foreign.empty()) return;
  std::string names;
  for (const std::string& name : foreign) names += (names.empty() ? "" : ", ") + name;
  warnings->push_back(
      "the output folder also holds files stillmap did not write, left "
      "as they are: " +
      names);
}

// The finished map's files and the build's own, with their figures; `posed` moves into the map
// frame, and so does finished->cloud.
void WriteOutputs(const BuildRequest& request, const BuildInputs& inputs,
                  FinishedBuildMap* finished, PosedFrames* posed, OutputSet& outputs,
                  BuildResult* result, MemoryLedger& memory) {
  result->map = finished->figures;
  result->map_frame = finished->frame;
  result->grid = std::move(finished->grid);
  result->timings.map_cleaning_ms = finished->cleaning_ms;
  result->timings.grid_ms = finished->grid_ms;
  memory.Phase("writing the map files (cloud, OctoMap and mesh at once)");
  result->mesh = WriteMapFiles(finished->map, &finished->cloud, finished->frame, result->grid,
                               MapFileOptionsOf(request), outputs, &result->timings);
  memory.Phase("writing session.bin, the trajectory and config.yaml");
  WriteBuildFiles(posed, finished->frame, inputs, request.config, request.sequence_dir,
                  result->poses, outputs);
  result->frames.fused = result->map.statistics.frames;
  result->frames.tracked = posed->trajectory.size();
  const size_t linked = static_cast<size_t>(
      std::count_if(result->segments.begin(), result->segments.end(),
                    [](const SegmentSummary& s) { return s.join == SegmentJoin::kLinked; }));
  Append(MapWarnings(result->map, result->map_frame, request.config.mapping, linked),
         &result->warnings);
}

}  // namespace

// Every top-level name a build writes (folders end with '/'): a rerun replaces all of them, so
// that no file of an earlier run stays beside the new set (a grid when the OctoMap is now off).
const std::vector<std::string>& BuildOutputNames() {
  static const std::vector<std::string> kNames = {
      "map.ply",  "map.pcd",     "map.bt",      "map.ot",      "trajectory.txt", "keyframes.txt",
      "grid.pgm", "grid.yaml",   "mesh.glb",    "mesh.obj",    "mesh.mtl",       "mesh.ply",
      "renders/", "config.yaml", "report.json", "report.html", "session.bin",    "segments/"};
  return kNames;
}

BuildResult RunBuild(const BuildRequest& request) {
  const Clock::time_point start = Clock::now();
  const double process_cpu_start_s = ProcessCpuSeconds();
  const std::vector<CoreTimes> cores_at_start = ReadCoreTimes();
  CheckRequest(request);
  BuildResult result;
  result.sequence_dir = request.sequence_dir;
  result.command_line = request.command_line;
  result.started_utc = fmt::format("{:%Y-%m-%dT%H:%M:%SZ}", fmt::gmtime(std::time(nullptr)));
  result.poses = request.poses();
  result.threads = request.threads();
  // The inputs and the detector are checked before anything is written.
  OpenedInputs opened = OpenInputs(InputOptionsOf(request));
  const BuildInputs& inputs = opened.inputs;
  result.frames = opened.frames;
  result.given_poses = opened.given;
  Append(std::move(opened.warnings), &result.warnings);
  result.camera = inputs.camera;
  MemoryLedger memory;
  memory.Phase("setting up: the detector");
  const double before_masks_mib = ResidentMemoryMib();
  MaskSetup masks = SetUpMasks(MaskOptionsOf(request), inputs.camera);
  memory.AddFixed(kDetectorMemoryOwner, ResidentMemoryMib() - before_masks_mib);
  result.masking = masks.figures;
  Append(std::move(masks.warnings), &result.warnings);

  // Locks the output folder and stages the outputs aside until all are written.
  OutputSet outputs(request.output_dir, "build", BuildOutputNames());
  AddOutputFolderWarnings(outputs, &result.warnings);

  MapperOptions mapper_options = request.config.mapping;
  mapper_options.in_background = mapper_options.in_background && request.threads() > 1;
  const GridOptions& grid = request.config.grid;
  Mapper mapper(inputs.camera, mapper_options,
                grid.enabled && grid.min_unseen_layer_m > 0.0 && mapper_options.occupancy.enabled);
  const double loop_cpu_start = ThreadCpuMs();
  memory.Phase("frame loop");
  LoopResult loop = RunPoseLoop(inputs, LoopOptionsOf(request), *masks.stage, mapper, memory);
  PosedFrames posed = std::move(loop.posed);
  std::vector<ApartSegment> apart = std::move(loop.apart);
  const double depth_unit_m = posed.session_depth_unit_m;  // of the kept keyframes' depth
  TakeLoopFigures(std::move(loop), &result);
  const double finish_cpu_start = ThreadCpuMs();
  result.timings.frame_loop_cpu_ms = finish_cpu_start - loop_cpu_start;
  ReleaseFreedMemory();  // the tracker's keyframes, landmarks and place index
  memory.Phase("finishing: the last fusion");
  FinishedMap map = mapper.Finish();
  result.timings.processing_ms = SecondsSince(start) * 1000.0;
  memory.Sample("finishing: the map handed over", FinishingOwners(map, {}, posed));

  const Clock::time_point write_start = Clock::now();
  memory.Phase("finishing: cleaning, floor and grid");
  FinishedBuildMap finished =
      FinishMapInFrame(std::move(map), posed, inputs, result.masking, MapFinishOptionsOf(request));
  memory.Sample("finishing: the map cleaned and in its frame",
                FinishingOwners(finished.map, finished.cloud, posed));
  WriteOutputs(request, inputs, &finished, &posed, outputs, &result, memory);
  memory.Sample("finishing: the map files written",
                FinishingOwners(finished.map, finished.cloud, posed));
  if (!apart.empty()) {
    memory.Phase("writing the segments kept apart");
    const SegmentOutputContext context{inputs,
                                       request.config,
                                       request.sequence_dir,
                                       result.masking,
                                       MapFinishOptionsOf(request),
                                       MapFileOptionsOf(request),
                                       depth_unit_m};
    Append(WriteApartSegments(std::move(apart), context, outputs), &result.warnings);
  }
  result.timings.write_ms = MillisecondsSince(write_start);
  result.timings.finish_cpu_ms = ThreadCpuMs() - finish_cpu_start;
  result.timings.process_cpu_ms = (ProcessCpuSeconds() - process_cpu_start_s) * 1000.0;
  result.timings.core_busy = CoreBusyShares(cores_at_start, ReadCoreTimes());
  result.wall_time_s = SecondsSince(start);
  result.frames_per_second = static_cast<double>(result.frames.pairs_used) / result.wall_time_s;
  result.memory = memory.Finish();  // its readings lie within the peak read after it
  result.peak_memory_mib = PeakMemoryMib();

  // Not counted in the speed above.
  result.evaluation =
      EvaluateBuild(inputs, EvaluationOptionsOf(request), posed, finished.cloud, result.grid);
  if (request.config.render.enabled) {
    const Clock::time_point renders_start = Clock::now();
    result.renders = WriteRenders(
        std::move(finished.cloud),
        {&result.grid, &posed, &result.evaluation.ate, SequenceName(request.sequence_dir)},
        request.config.render, outputs);
    result.timings.renders_ms = MillisecondsSince(renders_start);
  }
  Append(outputs.SetAsideWarnings({"report.json", "report.html"}), &result.warnings);
  const nlohmann::json report = ReportJson(result, request.config);
  WriteText(outputs.TemporaryPath("report.json"), report.dump(2) + "\n", "report.json");
  WriteText(outputs.TemporaryPath("report.html"), ReportHtml(report), "report.html");
  outputs.Commit();
  return result;
}

}  // namespace stillmap
