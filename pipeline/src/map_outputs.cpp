#include "map_outputs.h"

#include <fmt/format.h>

#include <chrono>
#include <fstream>
#include <future>

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

// Why a build ends without a map, from the figures that explain it: an empty map is a failed run
// (exit 1, nothing written), not a set of empty files that look like a result.
std::string EmptyMapMessage(const MapFigures& map, const MapperOptions& options,
                            const BuildResult& result) {
  std::string message = fmt::format(
      "the map is empty: {} frames fused, {} depth readings within [{}, {}] m (mapping.min_depth, "
      "mapping.max_depth) outside the masks",
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

// The 2-D grid for planners, from the OctoMap; the floor is fitted to it and checked against the
// fused cameras' mean up direction (camera -y).
std::optional<OccupancyGrid> WriteGridFiles(const FinishedMap& map, const PosedFrames& posed,
                                            const GridOptions& options, OutputSet& outputs) {
  if (!options.enabled || map.occupancy == nullptr) return std::nullopt;
  const FloorPlane floor =
      FindFloor(*map.occupancy, MeanCameraUp(WorldFromCameras(posed.fused_poses)), options);
  OccupancyGrid grid = ProjectToGrid(*map.occupancy, floor, options);
  WriteGrid(grid, outputs.TemporaryPath("grid.pgm"), outputs.TemporaryPath("grid.yaml"),
            "grid.pgm");
  return grid;
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

void WriteTrajectoryFiles(const PosedFrames& posed, bool tracking, OutputSet& outputs) {
  posed.trajectory.WriteTum(outputs.TemporaryPath("trajectory.txt"),
                            tracking ? "stillmap trajectory (camera-to-world, every tracked frame)"
                                     : "stillmap trajectory (camera-to-world, ground-truth poses)");
  Trajectory(posed.fused_poses)
      .WriteTum(outputs.TemporaryPath("keyframes.txt"),
                tracking ? "stillmap keyframes fused into the map (camera-to-world, final poses)"
                         : "stillmap keyframes fused into the map (every frame with a pose)");
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
  if (!out.flush()) throw std::runtime_error("could not write config.yaml");
}

MapFigures Figures(const FinishedMap& map, const MapCleaningResult& cleaning) {
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

// Warnings about the finished map that the figures alone do not make plain.
void AddMapWarnings(const MapFigures& map, const MapperOptions& options, BuildResult* result) {
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
}

}  // namespace

std::vector<VoxelPoint> WriteMapOutputs(FinishedMap map, const PosedFrames& posed,
                                        const BuildRequest& request, const Camera& camera,
                                        OutputSet& outputs, BuildResult* result) {
  const BuildConfig& config = request.config;
  const Clock::time_point write_start = Clock::now();
  StageTimings& timings = result->timings;
  MapCleaningResult cleaning;
  std::future<void> clean_job = std::async(Policy(request), [&] {
    const Clock::time_point start = Clock::now();
    cleaning = map.CleanCloud(config.mapping.cleaning, camera);
    timings.map_cleaning_ms = MillisecondsSince(start);
  });
  map.WriteOccupancy(outputs.TemporaryPath("map.bt"), outputs.TemporaryPath("map.ot"));
  const Clock::time_point grid_start = Clock::now();
  result->grid = WriteGridFiles(map, posed, config.grid, outputs);
  if (result->grid) timings.grid_ms = MillisecondsSince(grid_start);
  clean_job.get();
  result->map = Figures(map, cleaning);
  // The cloud's points, once, for the cloud files, the mesh, the map quality and the renders.
  std::vector<VoxelPoint> cloud = map.cloud.Points();
  if (cloud.empty()) {
    throw std::runtime_error(EmptyMapMessage(result->map, config.mapping, *result));
  }
  std::future<void> mesh_job;
  if (config.mesh.enabled) {
    const std::string mesh_path = outputs.TemporaryPath(config.mesh.FileName());
    mesh_job = std::async(Policy(request), [&cloud, &config, &timings, result, mesh_path] {
      const Clock::time_point start = Clock::now();
      result->mesh = WriteMesh(cloud, config.mesh, mesh_path);
      timings.mesh_ms = MillisecondsSince(start);
    });
  }
  WriteCloudFiles(outputs.TemporaryPath("map.ply"), outputs.TemporaryPath("map.pcd"), cloud,
                  config.mapping.voxel.leaf_size);
  WriteTrajectoryFiles(posed, result->tracked(), outputs);
  WriteConfig(request, outputs);
  if (mesh_job.valid()) mesh_job.get();
  timings.write_ms = MillisecondsSince(write_start);
  result->frames.fused = result->map.statistics.frames;
  result->frames.tracked = posed.trajectory.size();
  AddMapWarnings(result->map, config.mapping, result);
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
