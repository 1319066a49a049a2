#include "map_outputs.h"

#include <fmt/format.h>

#include <chrono>
#include <fstream>
#include <future>

#include "map_frame.h"
#include "session_output.h"
#include "stillmap/io/error.h"
#include "stillmap/io/image_io.h"
#include "stillmap/io/timing.h"
#include "stillmap/mapping/map_mesh.h"
#include "stillmap/mapping/occupancy_grid.h"
#include "stillmap/viewer/renders.h"
#include "stillmap/viewer/trajectory_plot.h"

namespace stillmap {
namespace {

using Clock = std::chrono::steady_clock;

std::launch Policy(const BuildRequest& request) {
  return request.threads > 1 ? std::launch::async : std::launch::deferred;
}

// Why a build ends without a map, from the figures that explain it: an empty or nearly empty map
// (`points` in all) is a failed run (exit 1, nothing written), not files that look like a result.
std::string EmptyMapMessage(size_t points, const MapFigures& map, const MapperOptions& options,
                            const BuildResult& result) {
  std::string message = fmt::format(
      "the map is {}: {} frames fused, {} depth readings within [{}, {}] m (mapping.min_depth, "
      "mapping.max_depth) outside the masks",
      points == 0 ? "empty"
                  : fmt::format("nearly empty ({} points, fewer than mapping.min_map_points={})",
                                points, options.min_map_points),
      map.statistics.frames, map.statistics.points, options.back_projection.min_depth,
      options.back_projection.max_depth);
  if (map.voxels_out_of_range > 0) {
    message += fmt::format(", {} of them beyond the voxel grid's range (poses far from the origin)",
                           map.voxels_out_of_range);
  }
  const MapCleaningResult& cleaning = map.cleaning;
  const size_t cleaned = cleaning.seen_through + cleaning.seen_through_views + cleaning.outliers;
  if (cleaned > 0) message += fmt::format(", {} voxels removed by the map cleaning", cleaned);
  if (result.masking.enabled) {
    message += fmt::format("; {:.1f} % of the pixels were masked as moving",
                           100 * result.masking.statistics.MeanShare());
  }
  return message + ". Check the depth scale (camera.depth_factor), the depth range and the poses";
}

// The floor fitted to the OctoMap's occupied voxels or, without one, to the cloud thinned to grid
// cells (RefineFloor then moves it onto the clean cloud); checked against the fused cameras' mean
// up direction (camera -y).
FloorPlane MapFloor(const FinishedMap& map, const std::vector<VoxelPoint>* cloud,
                    const PosedFrames& posed, const GridOptions& options) {
  const Eigen::Vector3d cameras_up = MeanCameraUp(WorldFromCameras(posed.fused_poses));
  if (map.occupancy) return FindFloor(*map.occupancy, cameras_up, options);
  return FindFloor(*cloud, options.resolution, cameras_up, options);
}

// The 2-D grid for planners, from the OctoMap (in the poses' frame) and the cleaned cloud, in
// the floor frame; written in the map frame.
std::optional<OccupancyGrid> WriteGridFiles(const FinishedMap& map,
                                            const std::vector<VoxelPoint>& cloud,
                                            const Eigen::Vector3d& start,
                                            const MapFrameFigures& frame,
                                            const GridOptions& options, OutputSet& outputs) {
  if (!options.enabled || map.occupancy == nullptr) return std::nullopt;
  GridSources sources;
  sources.map = map.occupancy.get();
  sources.floor = frame.floor;
  sources.world_from_grid = frame.poses_from_map * frame.map_from_floor;
  sources.cloud = &cloud;
  sources.start = start;
  OccupancyGrid grid = ProjectToGrid(sources, options);
  grid.world_from_grid = frame.map_from_floor;
  WriteGrid(grid, outputs.TemporaryPath("grid.pgm"), outputs.TemporaryPath("grid.yaml"),
            "grid.pgm");
  return grid;
}

bool IsIdentity(const Eigen::Isometry3d& transform) {
  return (transform.matrix() - Eigen::Matrix4d::Identity()).norm() < 1e-12;
}

// The OctoMap files, in the map frame (resampled when it is not the poses' frame).
void WriteOccupancyFiles(const FinishedMap& map, const MapFrameFigures& frame, OutputSet& outputs) {
  if (!map.occupancy) return;
  const std::string bt = outputs.TemporaryPath("map.bt"), ot = outputs.TemporaryPath("map.ot");
  if (IsIdentity(frame.poses_from_map)) {
    map.occupancy->WriteBinary(bt);
    map.occupancy->WriteFull(ot);
    return;
  }
  const OccupancyMap in_map = map.occupancy->Transformed(frame.poses_from_map.inverse());
  in_map.WriteBinary(bt);
  in_map.WriteFull(ot);
}

void MoveToMap(const Eigen::Isometry3d& map_from_poses, std::vector<VoxelPoint>* cloud) {
  if (IsIdentity(map_from_poses)) return;
  const Eigen::Isometry3f transform = map_from_poses.cast<float>();
  for (VoxelPoint& point : *cloud) point.position = transform * point.position;
}

// The mesh of the voxel cloud (throws for an empty one).
MeshFigures WriteMesh(const std::vector<VoxelPoint>& cloud, const MapMeshOptions& options,
                      const std::string& path) {
  const ColoredMesh mesh = VoxelSurfaceMesh(cloud, options);
  if (mesh.faces.empty()) {
    throw std::runtime_error(
        fmt::format("the mesh is empty: no {} m voxel holds mesh.min_points={} map points; lower "
                    "mesh.min_points or set mesh.enabled=false",
                    options.voxel, options.min_points));
  }
  WriteColoredMesh(path, mesh, options.format);
  return {options.FileName(), mesh.voxels, mesh.vertices.size(), mesh.faces.size()};
}

void WriteTrajectoryFiles(const PosedFrames& posed, bool tracking, const std::string& frame,
                          OutputSet& outputs) {
  const std::string in_frame = "; map frame " + frame;
  posed.trajectory.WriteTum(outputs.TemporaryPath("trajectory.txt"),
                            (tracking ? "stillmap trajectory (camera-to-map, every tracked frame)"
                                      : "stillmap trajectory (camera-to-map, ground-truth poses)") +
                                in_frame);
  Trajectory(posed.fused_poses)
      .WriteTum(outputs.TemporaryPath("keyframes.txt"),
                (tracking ? "stillmap keyframes fused into the map (camera-to-map, final poses)"
                          : "stillmap keyframes fused into the map (every frame with a pose)") +
                    in_frame);
}

// The effective configuration with the run's own settings as the request had them, so that
// `--config OUT/config.yaml` repeats the run.
void WriteConfig(const BuildRequest& request, OutputSet& outputs) {
  BuildConfig config = request.config;
  config.run.poses = request.poses == PoseSource::kGroundTruth ? "groundtruth" : "tracking";
  config.run.detector = request.detector;
  config.run.models = request.models_dir;
  config.run.threads = request.threads;
  std::ofstream out(outputs.TemporaryPath("config.yaml"));
  out << ConfigToYaml(config);
  if (!out.flush())
    throw std::runtime_error(WriteFailure(outputs.TemporaryPath("config.yaml"), "config.yaml"));
}

// Warnings about the finished map that the figures alone do not make plain.
void AddMapWarnings(const MapFigures& map, const BuildConfig& config, BuildResult* result) {
  const MapperOptions& options = config.mapping;
  if (result->tracking && result->tracking->statistics.new_maps > 0) {
    result->warnings.push_back(fmt::format(
        "tracking was lost and not relocalized {} time(s); each time a new local map was started "
        "from the last good pose and fused into the same cloud, so parts of the map may be "
        "misaligned copies (report.json: tracking.lost_frame_times)",
        result->tracking->statistics.new_maps));
  }
  if (map.voxels_out_of_range + map.octomap_points_out_of_range > 0) {
    result->warnings.push_back(fmt::format(
        "{} points of the voxel cloud and {} of the OctoMap lay beyond the maps' extent ({:.0f} m "
        "from the origin) and were left out: the poses went far astray",
        map.voxels_out_of_range, map.octomap_points_out_of_range, options.Extent()));
  }
  if (!options.occupancy.enabled) {
    result->warnings.push_back(
        "the OctoMap is off (octomap.enabled=false): no map.bt, map.ot or grid, and the "
        "cloud was not cleaned of voxels the cameras saw through");
  }
  if (!result->map_frame.floor_found && result->map_frame.name == "floor") {
    result->warnings.push_back(
        "no floor plane was found (report.json: map_frame.floor): the map "
        "frame's z is the cameras' mean up, gravity assumed");
  }
}

}  // namespace

MapFiles WriteMapFiles(const FinishedMap& map, std::vector<VoxelPoint>* cloud,
                       const MapFrameFigures& frame, const Eigen::Vector3d& start_in_poses,
                       const BuildConfig& config, bool parallel, OutputSet& outputs,
                       StageTimings* timings) {
  const std::launch policy = parallel ? std::launch::async : std::launch::deferred;
  MapFiles files;
  const Clock::time_point grid_start = Clock::now();
  files.grid = WriteGridFiles(map, *cloud, start_in_poses, frame, config.grid, outputs);
  timings->grid_ms = MillisecondsSince(grid_start);
  std::future<void> octomap_job =
      std::async(policy, [&] { WriteOccupancyFiles(map, frame, outputs); });
  MoveToMap(frame.poses_from_map.inverse(), cloud);
  std::future<void> mesh_job;
  if (config.mesh.enabled) {
    const std::string mesh_path = outputs.TemporaryPath(config.mesh.FileName());
    mesh_job = std::async(policy, [cloud, &config, timings, &files, mesh_path] {
      const Clock::time_point start = Clock::now();
      files.mesh = WriteMesh(*cloud, config.mesh, mesh_path);
      timings->mesh_ms = MillisecondsSince(start);
    });
  }
  WriteCloudFiles(outputs.TemporaryPath("map.ply"), outputs.TemporaryPath("map.pcd"), *cloud,
                  config.mapping.voxel.leaf_size, frame.description);
  octomap_job.get();
  if (mesh_job.valid()) mesh_job.get();
  return files;
}

MapFigures MapFiguresOf(const FinishedMap& map, const MapCleaningResult& cleaning) {
  MapFigures figures;
  figures.statistics = map.statistics;
  figures.cleaning = cleaning;
  figures.voxels = map.cloud.size();
  figures.voxels_written = map.cloud.OutputSize();
  figures.voxels_out_of_range = map.cloud.rejected_count();
  figures.voxel_table_mib = static_cast<double>(map.cloud.MemoryBytes()) / (1024.0 * 1024.0);
  if (map.occupancy) {
    figures.octomap_leaves = map.occupancy->LeafCount();
    figures.octomap_occupied_leaves = map.occupancy->OccupiedLeafCount();
    figures.octomap_points_out_of_range = map.occupancy->rejected_count();
  }
  return figures;
}

std::vector<VoxelPoint> WriteMapOutputs(FinishedMap map, PosedFrames* posed,
                                        const BuildInputs& inputs, const BuildRequest& request,
                                        OutputSet& outputs, BuildResult* result) {
  const BuildConfig& config = request.config;
  const Clock::time_point write_start = Clock::now();
  StageTimings& timings = result->timings;
  MapCleaningResult cleaning;
  std::future<void> clean_job = std::async(Policy(request), [&] {
    const Clock::time_point start = Clock::now();
    cleaning = map.CleanCloud(config.mapping.cleaning);
    timings.map_cleaning_ms = MillisecondsSince(start);
  });
  const Clock::time_point floor_start = Clock::now();
  std::optional<FloorPlane> fitted;
  if (map.occupancy) fitted = MapFloor(map, nullptr, *posed, config.grid);  // beside the cleaning
  double floor_ms = MillisecondsSince(floor_start);
  clean_job.get();
  result->map = MapFiguresOf(map, cleaning);
  // The cloud's points, once, for the cloud files, the mesh, the map quality and the renders.
  std::vector<VoxelPoint> cloud = map.cloud.Points();
  if (cloud.size() < static_cast<size_t>(config.mapping.min_map_points)) {
    throw std::runtime_error(EmptyMapMessage(cloud.size(), result->map, config.mapping, *result));
  }
  const Clock::time_point refine_start = Clock::now();
  // Two of the fit's cells (OctoMap voxels, or grid cells without an OctoMap) either side.
  const double band = 2.0 * (map.occupancy ? map.occupancy->resolution() : config.grid.resolution);
  const FloorPlane floor =
      RefineFloor(fitted ? *fitted : MapFloor(map, &cloud, *posed, config.grid), cloud, band);
  result->map_frame = ChooseMapFrame(floor, inputs, request, *posed);
  floor_ms += MillisecondsSince(refine_start);
  const MapFrameFigures& frame = result->map_frame;
  const Eigen::Vector3d start = posed->trajectory.poses().front().world_from_camera.translation();
  MapFiles files =
      WriteMapFiles(map, &cloud, frame, start, config, request.threads > 1, outputs, &timings);
  timings.grid_ms += floor_ms;
  result->grid = std::move(files.grid);
  if (config.mesh.enabled) result->mesh = files.mesh;
  const Eigen::Isometry3d map_from_poses = frame.poses_from_map.inverse();
  if (!posed->session_keyframes.empty()) {
    WriteSessionFile(std::move(posed->session_keyframes), posed->session_depth_unit_m, frame,
                     inputs, request.sequence_dir, outputs.TemporaryPath("session.bin"));
  }
  *posed = PosesInMap(*posed, map_from_poses);
  WriteTrajectoryFiles(*posed, result->tracked(), frame.name, outputs);
  WriteConfig(request, outputs);
  timings.write_ms = MillisecondsSince(write_start);
  result->frames.fused = result->map.statistics.frames;
  result->frames.tracked = posed->trajectory.size();
  AddMapWarnings(result->map, config, result);
  return cloud;
}

void WriteRenders(std::vector<VoxelPoint> cloud, const PosedFrames& posed,
                  const BuildRequest& request, OutputSet& outputs, BuildResult* result) {
  if (!request.config.render.enabled) return;
  const Clock::time_point start = Clock::now();
  RenderInput input;
  input.cloud = std::move(cloud);
  input.grid = result->grid;
  input.trajectory = WorldFromCameras(posed.trajectory.poses());
  input.keyframes = WorldFromCameras(posed.fused_poses);
  input.title = SequenceName(request.sequence_dir);
  std::vector<std::string> names;
  for (const auto& [name, image] : RenderViews(input, request.config.render)) {
    WriteImage(outputs.TemporaryPath("renders/" + name), image, ".png");
    names.push_back("renders/" + name);
  }
  if (result->evaluation.ate) {
    WriteImage(outputs.TemporaryPath("renders/trajectory_error.png"),
               DrawTrajectoryPlot(*result->evaluation.ate), ".png");
    names.push_back("renders/trajectory_error.png");
  }
  result->renders = names;
  result->timings.renders_ms = MillisecondsSince(start);
}

}  // namespace stillmap
