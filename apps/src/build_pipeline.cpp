#include "stillmap/apps/build_pipeline.h"

#include <spdlog/spdlog.h>
#include <sys/resource.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <future>
#include <nlohmann/json.hpp>
#include <optional>

#include "stillmap/apps/progress.h"
#include "stillmap/io/error.h"
#include "stillmap/io/output_files.h"
#include "stillmap/io/sequence.h"
#include "stillmap/io/trajectory.h"
#include "stillmap/mapping/map_io.h"
#include "stillmap/mapping/map_quality.h"
#include "stillmap/mapping/mapper.h"

namespace stillmap {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

double Seconds(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

double PeakMemoryMib() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return static_cast<double>(usage.ru_maxrss) / 1024.0;  // ru_maxrss is in KiB on Linux
}

// Removes the output folder on failure when this run created it and left it empty.
class CreatedFolderGuard {
 public:
  explicit CreatedFolderGuard(std::string dir) : dir_(std::move(dir)), existed_(fs::exists(dir_)) {}
  ~CreatedFolderGuard() {
    std::error_code error;
    if (!committed_ && !existed_ && fs::is_empty(dir_, error)) fs::remove(dir_, error);
  }
  void Commit() { committed_ = true; }

 private:
  std::string dir_;
  bool existed_;
  bool committed_ = false;
};

nlohmann::json CameraJson(const Camera& camera) {
  nlohmann::json json = {
      {"width", camera.width},
      {"height", camera.height},
      {"fx", camera.fx},
      {"fy", camera.fy},
      {"cx", camera.cx},
      {"cy", camera.cy},
      {"distortion", camera.distortion},
      {"depth_factor", camera.depth_factor},
      {"groundtruth_body_from_camera", camera.groundtruth_body_from_camera.has_value()}};
  return json;
}

}  // namespace

BuildSummary RunBuild(const BuildRequest& request) {
  const Clock::time_point start = Clock::now();
  const BuildConfig& config = request.config;
  config.Validate();
  if (request.threads < 1) throw InputError("--threads must be at least 1");
  if (!fs::is_directory(request.sequence_dir)) {
    throw InputError(request.sequence_dir +
                     ": sequence folder not found (expected a TUM-layout folder with rgb.txt and "
                     "depth.txt)");
  }
  if (request.poses == PoseSource::kTracking) {
    throw InputError(
        "camera tracking is not part of this stillmap build yet; map from known poses with "
        "--poses groundtruth");
  }

  // Inputs are checked before anything is written.
  const Camera camera = ResolveCamera(request.sequence_dir, config.camera);
  const Sequence sequence = Sequence::Open(request.sequence_dir, camera, config.sequence);
  if (!sequence.groundtruth()) {
    throw InputError(request.sequence_dir +
                     ": no groundtruth.txt; --poses groundtruth needs the sequence's ground truth");
  }
  const size_t total_pairs = sequence.frames().size();
  if (config.first_frame >= total_pairs) {
    throw InputError("sequence.first_frame=" + std::to_string(config.first_frame) +
                     " but the sequence has " + std::to_string(total_pairs) + " color/depth pairs");
  }
  const size_t end = config.max_frames == 0
                         ? total_pairs
                         : std::min(total_pairs, config.first_frame + config.max_frames);

  // Poses first: frames without one are not decoded at all.
  std::vector<size_t> frame_indices;
  std::vector<StampedPose> poses;
  for (size_t i = config.first_frame; i < end; ++i) {
    const double time = sequence.frames()[i].time;
    const std::optional<Eigen::Isometry3d> world_from_camera =
        sequence.groundtruth()->Interpolate(time, config.sequence.max_groundtruth_gap);
    if (!world_from_camera) continue;
    frame_indices.push_back(i);
    poses.push_back({time, *world_from_camera});
  }
  BuildSummary summary;
  summary.frames_paired = end - config.first_frame;
  summary.frames_without_pose = summary.frames_paired - frame_indices.size();
  if (frame_indices.empty()) {
    throw InputError(request.sequence_dir +
                     ": no frame lies within the ground truth's time range (compare the timestamps "
                     "of rgb.txt and groundtruth.txt)");
  }
  if (summary.frames_without_pose > 0) {
    spdlog::warn(
        "{} of {} frames lie outside the ground truth (or across a gap wider than {} s) "
        "and are left out",
        summary.frames_without_pose, summary.frames_paired, config.sequence.max_groundtruth_gap);
  }

  CreatedFolderGuard folder_guard(request.output_dir);  // before the folder may be created
  PrepareOutputFolder(request.output_dir);
  OutputSet outputs(request.output_dir);

  MapperOptions mapper_options = config.mapping;
  mapper_options.occupancy_in_background = request.threads > 1;
  Mapper mapper(camera, mapper_options);
  ProgressLine progress("stillmap build", frame_indices.size(), request.show_progress);
  double load_s = 0.0;
  auto load = [&sequence](size_t index) { return sequence.LoadFrame(index); };
  std::future<Frame> next;
  if (request.threads > 1) next = std::async(std::launch::async, load, frame_indices[0]);
  for (size_t k = 0; k < frame_indices.size(); ++k) {
    const Clock::time_point load_start = Clock::now();
    Frame frame = request.threads > 1 ? next.get() : load(frame_indices[k]);
    load_s += Seconds(load_start);
    if (request.threads > 1 && k + 1 < frame_indices.size()) {
      next = std::async(std::launch::async, load, frame_indices[k + 1]);
    }
    MapperFrame input;
    input.time = frame.time;
    input.color = frame.color;
    input.depth_m = frame.depth_m;
    input.world_from_camera = poses[k].world_from_camera;
    mapper.Integrate(input);
    progress.Update(k + 1);
  }
  mapper.Finish();
  progress.Finish();
  const double processing_s = Seconds(start);

  // Outputs, each under a temporary name until all are written.
  const Clock::time_point write_start = Clock::now();
  mapper.WriteCloud(outputs.TemporaryPath("map.ply"), outputs.TemporaryPath("map.pcd"));
  if (mapper.occupancy() != nullptr) {
    mapper.WriteOccupancy(outputs.TemporaryPath("map.bt"), outputs.TemporaryPath("map.ot"));
  }
  const Trajectory trajectory(poses);
  trajectory.WriteTum(outputs.TemporaryPath("trajectory.txt"),
                      "stillmap trajectory (camera-to-world, ground-truth poses)");
  trajectory.WriteTum(outputs.TemporaryPath("keyframes.txt"),
                      "stillmap keyframes fused into the map (every frame with a pose)");
  {
    std::ofstream out(outputs.TemporaryPath("config.yaml"));
    out << ConfigToYaml(config);
    if (!out.flush()) throw std::runtime_error("could not write config.yaml");
  }
  const double write_s = Seconds(write_start);

  const MapperStatistics& stats = mapper.statistics();
  summary.frames_fused = stats.frames;
  summary.map_points = mapper.cloud().OutputSize();
  summary.octomap_leaves = mapper.occupancy() ? mapper.occupancy()->LeafCount() : 0;
  summary.wall_time_s = Seconds(start);
  summary.frames_per_second = static_cast<double>(summary.frames_paired) / summary.wall_time_s;
  summary.peak_memory_mib = PeakMemoryMib();

  const double n = static_cast<double>(stats.frames);
  nlohmann::json report;
  report["stillmap_version"] = STILLMAP_VERSION;
  report["sequence"] = request.sequence_dir;
  report["poses"] = "groundtruth";
  report["world_frame"] = "the ground truth's world frame";
  report["camera"] = CameraJson(camera);
  report["frames"] = {{"color_images", sequence.color_count()},
                      {"depth_images", sequence.depth_count()},
                      {"pairs_in_sequence", total_pairs},
                      {"pairs_used", summary.frames_paired},
                      {"without_pose", summary.frames_without_pose},
                      {"fused", summary.frames_fused}};
  report["keyframes"] = {{"fused", summary.frames_fused},
                         {"rejected_invalid", 0},
                         {"rejected_redundant", 0},
                         {"selection", "none: with known poses every frame is fused"}};
  report["dynamic_share"] = 0.0;
  report["masking"] = "none";
  report["map"] = {{"voxel_leaf_m", config.mapping.voxel.leaf_size},
                   {"points_fused", stats.points},
                   {"voxels", mapper.cloud().size()},
                   {"voxels_written", summary.map_points},
                   {"min_points_per_voxel", config.mapping.voxel.min_points_per_voxel},
                   {"voxels_out_of_range", mapper.cloud().rejected_count()},
                   {"voxel_table_mib", mapper.cloud().MemoryBytes() / (1024.0 * 1024.0)},
                   {"octomap_enabled", config.mapping.occupancy_enabled},
                   {"octomap_resolution_m", config.mapping.occupancy.resolution},
                   {"octomap_leaves", summary.octomap_leaves},
                   {"octomap_occupied_leaves",
                    mapper.occupancy() ? mapper.occupancy()->OccupiedLeafCount() : 0}};
  report["timing_ms"] = {{"load_wait_total", load_s * 1000.0},
                         {"back_projection_total", stats.back_projection_ms},
                         {"voxel_total", stats.voxel_ms},
                         {"octomap_total", stats.occupancy_ms},
                         {"octomap_wait_total", stats.occupancy_wait_ms},
                         {"write_outputs", write_s * 1000.0},
                         {"per_frame",
                          {{"load_wait", load_s * 1000.0 / n},
                           {"back_projection", stats.back_projection_ms / n},
                           {"voxel", stats.voxel_ms / n},
                           {"octomap", stats.occupancy_ms / n},
                           {"octomap_wait", stats.occupancy_wait_ms / n},
                           {"total", processing_s * 1000.0 / n}}}};
  report["wall_time_s"] = summary.wall_time_s;
  report["frames_per_second"] = summary.frames_per_second;
  report["peak_memory_mib"] = summary.peak_memory_mib;
  report["threads"] = request.threads;
  // Map quality against the static ground truth of synthetic sequences (not counted in the
  // frames per second above).
  const fs::path static_groundtruth = fs::path(request.sequence_dir) / "static_gt.ply";
  if (fs::exists(static_groundtruth)) {
    const Clock::time_point evaluation_start = Clock::now();
    const MapQuality quality =
        EvaluateMap(mapper.cloud().Points(), ReadCloud(static_groundtruth.string()));
    summary.map_quality = quality;
    report["map_quality"] = {{"groundtruth", static_groundtruth.string()},
                             {"map_points", quality.map_points},
                             {"groundtruth_points", quality.groundtruth_points},
                             {"accuracy_mean_m", quality.accuracy_mean},
                             {"accuracy_median_m", quality.accuracy_median},
                             {"completeness", quality.completeness},
                             {"ghost_share", quality.ghost_share},
                             {"evaluation_s", Seconds(evaluation_start)}};
  }
  report["trajectory_error"] = nullptr;
  report["trajectory_error_note"] = "not evaluated: the poses are the ground truth";
  {
    std::ofstream out(outputs.TemporaryPath("report.json"));
    out << report.dump(2) << "\n";
    if (!out.flush()) throw std::runtime_error("could not write report.json");
  }
  outputs.Commit();
  folder_guard.Commit();
  return summary;
}

}  // namespace stillmap
