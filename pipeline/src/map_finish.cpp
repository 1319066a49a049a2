#include "map_finish.h"

#include <fmt/format.h>

#include <chrono>
#include <future>

#include "stillmap/io/cpu_usage.h"
#include "stillmap/io/option_names.h"
#include "stillmap/io/timing.h"
#include "stillmap/mapping/band_coverage.h"

namespace stillmap {
namespace {

// The grid's unseen layers are found in layers this thick [m]: a table's top is 2-5 cm.
constexpr double kUnseenLayerStepM = 0.01;

using Clock = std::chrono::steady_clock;

// The free cells of `grid` over which the views' rays leave a layer unseen
// (GridOptions::min_unseen_layer_m) made unknown; returns how many. The views are cast in two
// halves on two threads when `parallel`, each into a coverage of its own, then joined: the same
// cells either way.
size_t UnknownWhereViewsLeaveLayersUnseen(const FinishedMap& map,
                                          const std::vector<KeyframeView>& views,
                                          const GridOptions& options, bool parallel,
                                          OccupancyGrid* grid) {
  std::vector<std::vector<Eigen::Vector2f>> rays(map.cameras.size());
  for (size_t camera = 0; camera < rays.size(); ++camera)
    rays[camera] = PixelRays(map.cameras[camera]);
  auto cast = [&](size_t first, size_t last) {
    BandCoverage coverage(*grid, kUnseenLayerStepM, options.unseen_layer_grazing_deg);
    for (size_t k = first; k < last; ++k) {
      const auto camera = static_cast<size_t>(views[k].camera);
      coverage.AddView(views[k], rays[camera], map.cameras[camera].width,
                       map.occupancy->max_range(), options.unseen_layer_block_step);
    }
    return coverage;
  };
  const size_t half = parallel ? views.size() / 2 : views.size();
  std::future<BandCoverage> second =
      std::async(parallel ? std::launch::async : std::launch::deferred, cast, half, views.size());
  BandCoverage coverage = cast(0, half);
  coverage.Join(second.get());
  return UnknownWhereLayersUnseen(coverage, options.min_unseen_layer_m, grid);
}

// Why a build ends without a map, from the figures that explain it: an empty or nearly empty map
// (`points` in all) is a failed run (exit 1, nothing written), not files that look like a result.
std::string EmptyMapMessage(size_t points, const MapFigures& map, const MapperOptions& options,
                            const MaskingFigures& masking) {
  std::string message = fmt::format(
      "the map is {}: {} frames fused, {} depth readings within [{}, {}] m ({}, {}) outside the "
      "masks",
      points == 0 ? "empty"
                  : fmt::format("nearly empty ({} points, fewer than {}={})", points,
                                OptionKey(options, options.min_map_points), options.min_map_points),
      map.statistics.frames, map.statistics.points, options.back_projection.min_depth,
      options.back_projection.max_depth, OptionKey(options, options.back_projection.min_depth),
      OptionKey(options, options.back_projection.max_depth));
  if (map.voxels_out_of_range > 0) {
    message += fmt::format(", {} of them beyond the voxel grid's range (poses far from the origin)",
                           map.voxels_out_of_range);
  }
  const MapCleaningResult& cleaning = map.cleaning;
  const size_t cleaned = cleaning.seen_through + cleaning.seen_through_views + cleaning.outliers;
  if (cleaned > 0) message += fmt::format(", {} voxels removed by the map cleaning", cleaned);
  if (masking.enabled) {
    message += fmt::format("; {:.1f} % of the pixels were masked as moving",
                           100 * masking.statistics.MeanShare());
  }
  return message + fmt::format(". Check the depth scale ({}), the depth range and the poses",
                               OptionKey(&CameraOverrides::depth_factor));
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

}  // namespace

FinishedBuildMap FinishMapInFrame(FinishedMap map, const PosedFrames& posed,
                                  const BuildInputs& inputs, const MaskingFigures& masking,
                                  const MapFinishOptions& options) {
  FinishedBuildMap out{std::move(map), {}, {}, {}, std::nullopt, 0.0, 0.0};
  FinishedMap& finished = out.map;
  MapCleaningResult cleaning;
  const std::launch policy = options.parallel ? std::launch::async : std::launch::deferred;
  std::future<void> clean_job = std::async(policy, [&] {
    const Clock::time_point start = Clock::now();
    cleaning = finished.CleanCloud(options.mapping.cleaning);
    out.cleaning_ms = MillisecondsSince(start);
  });
  const Clock::time_point floor_start = Clock::now();
  std::optional<FloorPlane> fitted;  // beside the cleaning
  if (finished.occupancy) fitted = MapFloor(finished, nullptr, posed, options.grid);
  double floor_ms = MillisecondsSince(floor_start);
  clean_job.get();
  out.figures = MapFiguresOf(finished, cleaning);
  // The cloud's points, once, for the cloud files, the mesh, the map quality and the renders;
  // the grid's views for its unseen layers, freed after it.
  const std::vector<KeyframeView> grid_views = std::move(finished.grid_views);
  out.cloud = finished.TakeCloudPoints();
  ReleaseFreedMemory();
  if (out.cloud.size() < static_cast<size_t>(options.mapping.min_map_points)) {
    throw std::runtime_error(
        EmptyMapMessage(out.cloud.size(), out.figures, options.mapping, masking));
  }
  const Clock::time_point refine_start = Clock::now();
  // Two of the fit's cells (OctoMap voxels, or grid cells without an OctoMap) either side.
  const double band =
      2.0 * (finished.occupancy ? finished.occupancy->resolution() : options.grid.resolution);
  const FloorPlane floor = RefineFloor(
      fitted ? *fitted : MapFloor(finished, &out.cloud, posed, options.grid), out.cloud, band);
  out.frame = ChooseMapFrame(floor, inputs, options.frame, posed);
  const Eigen::Vector3d start = posed.trajectory.poses().front().world_from_camera.translation();
  out.grid = ProjectMapGrid(finished, out.cloud, start, out.frame, options.grid, grid_views,
                            options.parallel);
  out.grid_ms = floor_ms + MillisecondsSince(refine_start);
  return out;
}

std::optional<OccupancyGrid> ProjectMapGrid(const FinishedMap& map,
                                            const std::vector<VoxelPoint>& cloud,
                                            const Eigen::Vector3d& start,
                                            const MapFrameFigures& frame,
                                            const GridOptions& options,
                                            const std::vector<KeyframeView>& views, bool parallel) {
  if (!options.enabled || map.occupancy == nullptr) return std::nullopt;
  GridSources sources;
  sources.map = map.occupancy.get();
  sources.floor = frame.floor;
  sources.world_from_grid = frame.poses_from_map * frame.map_from_floor;
  sources.cloud = &cloud;
  sources.start = start;
  OccupancyGrid grid = ProjectToGrid(sources, options);
  if (options.min_unseen_layer_m > 0.0 && !views.empty()) {
    grid.unseen_layer_cells =
        UnknownWhereViewsLeaveLayersUnseen(map, views, options, parallel, &grid);
  }
  grid.world_from_grid = frame.map_from_floor;
  return grid;
}

MapFigures MapFiguresOf(const FinishedMap& map, const MapCleaningResult& cleaning) {
  MapFigures figures;
  figures.statistics = map.statistics;
  figures.cleaning = cleaning;
  figures.voxels = map.cloud.size();
  figures.voxels_written = map.cloud.OutputSize();
  figures.voxels_out_of_range = map.cloud.rejected_count();
  figures.voxel_table_mib = static_cast<double>(map.cloud.TableBytes()) / (1024.0 * 1024.0);
  if (map.occupancy) {
    figures.octomap_leaves = map.occupancy->LeafCount();
    figures.octomap_occupied_leaves = map.occupancy->OccupiedLeafCount();
    figures.octomap_points_out_of_range = map.occupancy->rejected_count();
  }
  return figures;
}

std::vector<std::string> MapWarnings(const MapFigures& map, const MapFrameFigures& frame,
                                     const MapperOptions& options, size_t segments_linked) {
  std::vector<std::string> warnings;
  if (segments_linked > 0) {
    warnings.push_back(fmt::format(
        "tracking was lost and not relocalized {} time(s) where the map was later found again: "
        "each part after such a loss was placed in the map by the places it shares with the "
        "parts before (report.json: segments)",
        segments_linked));
  }
  if (map.voxels_out_of_range + map.octomap_points_out_of_range > 0) {
    warnings.push_back(fmt::format(
        "{} points of the voxel cloud and {} of the OctoMap lay beyond the maps' extent ({:.0f} m "
        "from the origin) and were left out: the poses went far astray",
        map.voxels_out_of_range, map.octomap_points_out_of_range, options.Extent()));
  }
  if (!options.occupancy.enabled) {
    warnings.push_back(
        fmt::format("the OctoMap is off ({}=false): no map.bt, map.ot or grid, and the "
                    "cloud was not cleaned of voxels the cameras saw through",
                    OptionKey(&OccupancyMapOptions::enabled)));
  }
  if (!frame.floor_found && frame.name == "floor") {
    warnings.push_back(
        "no floor plane was found (report.json: map_frame.floor): the map "
        "frame's z is the cameras' mean up, gravity assumed");
  }
  return warnings;
}

}  // namespace stillmap
