#include "map_outputs.h"

#include <fmt/format.h>

#include <chrono>
#include <fstream>
#include <future>

#include "session_output.h"
#include "stillmap/io/error.h"
#include "stillmap/io/image_io.h"
#include "stillmap/io/option_names.h"
#include "stillmap/io/timing.h"
#include "stillmap/viewer/trajectory_plot.h"

namespace stillmap {
namespace {

using Clock = std::chrono::steady_clock;

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
        fmt::format("the mesh is empty: no {} m voxel holds {}={} map points; lower {} or set "
                    "{}=false",
                    options.voxel, OptionKey(options, options.min_points), options.min_points,
                    OptionKey(options, options.min_points), OptionKey(options, options.enabled)));
  }
  WriteColoredMesh(path, mesh, options.format);
  return {options.FileName(), mesh.voxels, mesh.vertices.size(), mesh.faces.size()};
}

void WriteTrajectoryFiles(const PosedFrames& posed, PoseSource poses, const std::string& frame,
                          OutputSet& outputs) {
  const std::string in_frame = "; map frame " + frame;
  const bool tracking = poses == PoseSource::kTracking;
  const char* what = tracking                            ? "every tracked frame"
                     : poses == PoseSource::kGroundTruth ? "ground-truth poses"
                                                         : "given poses";
  posed.trajectory.WriteTum(
      outputs.TemporaryPath("trajectory.txt"),
      fmt::format("stillmap trajectory (camera-to-map, {})", what) + in_frame);
  Trajectory(posed.fused_poses)
      .WriteTum(outputs.TemporaryPath("keyframes.txt"),
                (tracking ? "stillmap keyframes fused into the map (camera-to-map, final poses)"
                          : "stillmap keyframes fused into the map (every frame with a pose)") +
                    in_frame);
}

}  // namespace

void WriteText(const std::string& path, const std::string& text, const char* name) {
  std::ofstream out(path);
  out << text;
  if (!out.flush()) throw std::runtime_error(WriteFailure(path, name));
}

std::optional<MeshFigures> WriteMapFiles(const FinishedMap& map, std::vector<VoxelPoint>* cloud,
                                         const MapFrameFigures& frame,
                                         const std::optional<OccupancyGrid>& grid,
                                         const MapFileOptions& options, OutputSet& outputs,
                                         StageTimings* timings) {
  const std::launch policy = options.parallel ? std::launch::async : std::launch::deferred;
  const Clock::time_point grid_start = Clock::now();
  if (grid) {
    WriteGrid(*grid, outputs.TemporaryPath("grid.pgm"), outputs.TemporaryPath("grid.yaml"),
              "grid.pgm");
  }
  timings->grid_ms += MillisecondsSince(grid_start);
  std::future<void> octomap_job =
      std::async(policy, [&] { WriteOccupancyFiles(map, frame, outputs); });
  MoveToMap(frame.poses_from_map.inverse(), cloud);
  std::optional<MeshFigures> mesh;
  std::future<void> mesh_job;
  if (options.mesh.enabled) {
    const std::string mesh_path = outputs.TemporaryPath(options.mesh.FileName());
    mesh_job = std::async(policy, [cloud, &options, timings, &mesh, mesh_path] {
      const Clock::time_point start = Clock::now();
      mesh = WriteMesh(*cloud, options.mesh, mesh_path);
      timings->mesh_ms = MillisecondsSince(start);
    });
  }
  WriteCloudFiles(outputs.TemporaryPath("map.ply"), outputs.TemporaryPath("map.pcd"), *cloud,
                  options.voxel_leaf_m, frame.description);
  octomap_job.get();
  if (mesh_job.valid()) mesh_job.get();
  return mesh;
}

void WriteBuildFiles(PosedFrames* posed, const MapFrameFigures& frame, const BuildInputs& inputs,
                     const BuildConfig& config, const std::string& sequence_dir, PoseSource poses,
                     OutputSet& outputs) {
  if (!posed->session_keyframes.empty()) {
    WriteSessionFile(std::move(posed->session_keyframes), posed->session_depth_unit_m, frame,
                     inputs, sequence_dir, outputs.TemporaryPath("session.bin"));
  }
  *posed = PosesInMap(*posed, frame.poses_from_map.inverse());
  WriteTrajectoryFiles(*posed, poses, frame.name, outputs);
  WriteText(outputs.TemporaryPath("config.yaml"), ConfigToYaml(config), "config.yaml");
}

std::vector<std::string> WriteRenders(std::vector<VoxelPoint> cloud, const RenderSources& sources,
                                      const RenderOptions& options, OutputSet& outputs) {
  RenderInput input;
  input.cloud = std::move(cloud);
  input.grid = *sources.grid;
  input.trajectory = WorldFromCameras(sources.posed->trajectory.poses());
  input.keyframes = WorldFromCameras(sources.posed->fused_poses);
  input.title = sources.title;
  std::vector<std::string> names;
  for (const auto& [name, image] : RenderViews(input, options)) {
    WriteImage(outputs.TemporaryPath("renders/" + name), image, ".png");
    names.push_back("renders/" + name);
  }
  if (*sources.ate) {
    WriteImage(outputs.TemporaryPath("renders/trajectory_error.png"),
               DrawTrajectoryPlot(**sources.ate), ".png");
    names.push_back("renders/trajectory_error.png");
  }
  return names;
}

}  // namespace stillmap
