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
#include "map_outputs.h"
#include "pose_loops.h"
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
  if (request.threads < 1) throw InputError("--threads must be at least 1");
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
  cv::setNumThreads(std::min(request.threads, cores));
#endif
}

// The mask stage with its detector (loaded here, so that its errors come before any output).
std::unique_ptr<MaskStage> MakeMaskStage(const BuildRequest& request, const Camera& camera,
                                         BuildResult* result) {
  const BuildConfig& config = request.config;
  std::unique_ptr<Detector> detector;
  if (config.masking_enabled) {
    detector = MakeDetector(request.detector, request.models_dir, MotionLevels(config),
                            {config.fastest, config.yolox, config.deeplab});
    if (request.detector == "auto" && detector == nullptr && config.masking.semantics) {
      result->warnings.push_back(
          (request.models_dir.empty() ? "no detector model in " + DescribeModelSearchPath()
                                      : "no detector model under '" + request.models_dir + "'") +
          ": moving objects are found by geometry only, and people who stand still stay in the "
          "map (scripts/fetch-models gets the model; or pass --models DIR holding "
          "yolo_fastest_1.1/ or yolox_nano/, "
          "or --detector none to silence this)");
    }
  }
  // One thread runs the same schedule (the detector when its result is due): the same masks.
  auto masks = std::make_unique<MaskStage>(
      camera, config.masking, config.masking_enabled, std::move(detector),
      config.masking.detector_in_background, request.sequence_dir, request.threads > 1);
  result->masking.enabled = masks->enabled();
  result->masking.detector = masks->detector_name();
  result->masking.semantics = masks->semantics();
  result->masking.options = masks->options();
  if (masks->semantics()) {
    result->masking.models_dir = request.models_dir;
    result->masking.models_found_by = request.models_found_by;
  }
  return masks;
}

PosedFrames RunPoseLoop(const BuildInputs& inputs, const BuildRequest& request, MaskStage& masks,
                        Mapper& mapper, BuildResult* result) {
  const BuildConfig& config = request.config;
  ProgressLine progress("stillmap build", inputs.frame_indices.size(), request.show_progress);
  std::optional<FlowTracker> flow;
  if (config.masking_enabled && config.masking.TracksFlow()) {
    // The mask stage resolved the corner count and the KLT window.
    flow.emplace(masks.options().flow_points, masks.options().flow);
  }
  FrameReader reader(inputs.sequence, inputs.frame_indices, request.threads > 1, std::move(flow));
  const LoopStages stages{reader, masks, mapper, progress};
  PosedFrames posed = result->tracked() ? RunTrackedLoop(inputs, request, stages, result)
                                        : RunGroundTruthLoop(inputs, config, stages);
  progress.Finish();
  result->timings.reader_cpu_ms = reader.ahead_cpu_ms();
  result->timings.load_wait_ms = reader.wait_ms();
  result->timings.flow_ms = reader.flow_ms();
  const StreamChecks& checks = reader.checks();
  result->frames.depth_median_m = checks.DepthQuantile(0.5);
  result->frames.depth_95th_percentile_m = checks.DepthQuantile(0.95);
  result->frames.frozen_colour = checks.frozen_colour_frames();
  for (std::string& warning : checks.Warnings(inputs.camera.depth_factor)) {
    result->warnings.push_back(std::move(warning));
  }
  result->masking.statistics = masks.statistics();
  return posed;
}

void WriteText(const std::string& path, const std::string& text, const char* name) {
  std::ofstream out(path);
  out << text;
  if (!out.flush()) throw std::runtime_error(WriteFailure(path, name));
}

}  // namespace

// Every top-level name a build writes (folders end with '/'): a rerun replaces all of them, so
// that no file of an earlier run stays beside the new set (a grid when the OctoMap is now off).
const std::vector<std::string>& BuildOutputNames() {
  static const std::vector<std::string> kNames = {
      "map.ply",  "map.pcd",     "map.bt",      "map.ot",      "trajectory.txt", "keyframes.txt",
      "grid.pgm", "grid.yaml",   "mesh.glb",    "mesh.obj",    "mesh.mtl",       "mesh.ply",
      "renders/", "config.yaml", "report.json", "report.html", "session.bin"};
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
  result.poses = request.poses;
  result.threads = request.threads;
  const BuildInputs inputs = OpenInputs(request, &result);  // checked before anything is written
  result.camera = inputs.camera;
  const std::unique_ptr<MaskStage> masks = MakeMaskStage(request, inputs.camera, &result);

  // Locks the output folder and stages the outputs aside until all are written.
  OutputSet outputs(request.output_dir, "build", BuildOutputNames());
  if (!outputs.recovery_note().empty()) result.warnings.push_back(outputs.recovery_note());
  const std::vector<std::string> foreign = outputs.ForeignNames();
  if (!foreign.empty()) {
    std::string names;
    for (const std::string& name : foreign) names += (names.empty() ? "" : ", ") + name;
    result.warnings.push_back(
        "the output folder also holds files stillmap did not write, left "
        "as they are: " +
        names);
  }

  MapperOptions mapper_options = request.config.mapping;
  mapper_options.in_background = mapper_options.in_background && request.threads > 1;
  Mapper mapper(inputs.camera, mapper_options);
  const double loop_cpu_start = ThreadCpuMs();
  PosedFrames posed = RunPoseLoop(inputs, request, *masks, mapper, &result);
  const double finish_cpu_start = ThreadCpuMs();
  result.timings.frame_loop_cpu_ms = finish_cpu_start - loop_cpu_start;
  FinishedMap map = mapper.Finish();
  result.timings.processing_ms = SecondsSince(start) * 1000.0;

  std::vector<VoxelPoint> cloud =
      WriteMapOutputs(std::move(map), &posed, inputs, request, outputs, &result);
  result.timings.finish_cpu_ms = ThreadCpuMs() - finish_cpu_start;
  result.timings.process_cpu_ms = (ProcessCpuSeconds() - process_cpu_start_s) * 1000.0;
  result.timings.core_busy = CoreBusyShares(cores_at_start, ReadCoreTimes());
  result.wall_time_s = SecondsSince(start);
  result.frames_per_second = static_cast<double>(result.frames.pairs_used) / result.wall_time_s;
  result.peak_memory_mib = PeakMemoryMib();

  EvaluateBuild(inputs, request, posed, cloud, &result);  // not counted in the speed above
  WriteRenders(std::move(cloud), posed, request, outputs, &result);
  for (std::string& warning : outputs.SetAsideWarnings({"report.json", "report.html"})) {
    result.warnings.push_back(std::move(warning));
  }
  const nlohmann::json report = ReportJson(result, request.config);
  WriteText(outputs.TemporaryPath("report.json"), report.dump(2) + "\n", "report.json");
  WriteText(outputs.TemporaryPath("report.html"), ReportHtml(report), "report.html");
  outputs.Commit();
  return result;
}

}  // namespace stillmap
