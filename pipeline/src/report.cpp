#include "stillmap/pipeline/report.h"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <filesystem>

#include "report_parts.h"
#include "report_poses.h"
#include "report_timing.h"
#include "report_tracking.h"
#include "stillmap/io/option_names.h"
#include "stillmap/pipeline/build_request.h"

namespace stillmap {
namespace {

using nlohmann::json;

}  // namespace

json StatisticsJson(const ErrorStatistics& statistics) {
  return {{"count", statistics.count},   {"rmse", statistics.rmse},       {"mean", statistics.mean},
          {"median", statistics.median}, {"std_dev", statistics.std_dev}, {"min", statistics.min},
          {"max", statistics.max}};
}

namespace {

json CameraJson(const Camera& camera) {
  return {{"width", camera.width},
          {"height", camera.height},
          {"fx", camera.fx},
          {"fy", camera.fy},
          {"cx", camera.cx},
          {"cy", camera.cy},
          {"distortion", camera.Coefficients()},
          {"depth_factor", camera.depth_factor},
          {"groundtruth_body_from_camera", camera.groundtruth_body_from_camera.has_value()}};
}

json FramesJson(const FrameCounts& frames) {
  return {{"color_images", frames.color_images},
          {"depth_images", frames.depth_images},
          {"pairs_in_sequence", frames.pairs_in_sequence},
          {"pairs_used", frames.pairs_used},
          {"without_pose", frames.without_pose},
          {"tracked", frames.tracked},
          {"fused", frames.fused},
          {"depth_median_m", frames.depth_median_m},
          {"depth_95th_percentile_m", frames.depth_95th_percentile_m},
          {"frozen_colour", frames.frozen_colour}};
}

// How the fused frames were chosen.
std::string SelectionText(const BuildResult& result, const BuildConfig& config) {
  if (result.tracked()) return config.selection.Describe();
  const GivenPoseOptions& poses = config.poses;
  if (result.poses != PoseSource::kGiven ||
      (poses.keyframe_distance_m <= 0.0 && poses.keyframe_angle_deg <= 0.0)) {
    return "none: with known poses every frame is fused";
  }
  const KeyframeSelectionOptions& selection = config.selection;
  std::string text = fmt::format(
      "a frame each {} m or {} deg the camera moved ({}, {}), its mask re-checked against the "
      "frames on both sides",
      poses.keyframe_distance_m, poses.keyframe_angle_deg,
      OptionKey(poses, poses.keyframe_distance_m), OptionKey(poses, poses.keyframe_angle_deg));
  if (!selection.enabled) return text;
  text += fmt::format("; invalid when more than {} of it is masked", selection.max_masked_share);
  if (selection.revisit.enabled) {
    text += fmt::format("; only the depth cells that frames fused {} or more before it did not see",
                        selection.revisit.keyframes_apart);
    if (selection.revisit.max_seen_share < 1.0) {
      text +=
          fmt::format(", none when they saw more than {} of it", selection.revisit.max_seen_share);
    }
  }
  return text;
}

json KeyframesJson(const BuildResult& result, const BuildConfig& config) {
  return {{"fused", result.frames.fused},
          {"rejected_invalid", result.selection.invalid},
          {"rejected_redundant", result.selection.redundant},
          // Not fused: fused keyframes of earlier visits saw its view (RevisitCells).
          {"rejected_seen_before", result.selection.seen_before},
          // Of those, judged at the final poses: only their rays went into the map (free space).
          {"rays_only", result.map.statistics.rays_only_frames},
          // Culled by the tracker when final: keyframes kept before them saw their view.
          {"culled", result.tracking ? result.tracking->statistics.keyframes_culled : 0},
          {"map_recheck_added_pixels", result.selection.recheck_additions},
          // Depth cells (16 px) of keyframes on revisits left out: an earlier visit fused them.
          {"revisit_cells_left_out", result.selection.revisit_cells_left_out},
          {"selection", SelectionText(result, config)}};
}

json MaskingJson(const MaskingFigures& masking) {
  json out = {{"enabled", masking.enabled}};
  if (!masking.enabled) return out;
  const MaskingStatistics& s = masking.statistics;
  const DynamicMaskOptions& options = masking.options;
  out["detector"] = masking.detector;
  out["semantics"] = masking.semantics;
  if (masking.semantics) {
    out["models"] = {{"folder", masking.models_dir}, {"found_by", masking.models_found_by}};
  }
  out["depth_check"] = options.depth_check;
  out["flow_check"] = options.flow_check;
  if (options.TracksFlow()) {
    out["flow_klt_window_px"] = options.flow.klt_window;
    out["flow_points"] = options.flow_points;
  }
  out["outline"] = OutlineModeName(options.outline);
  out["detector_interval"] = options.detector_interval;
  out["detector_in_background"] = s.detector_in_background;
  if (masking.semantics) {
    out["detector_runs"] = s.detector_runs;
    out["second_opinion_runs"] = s.second_opinion_runs;
  }
  out["frames"] = s.frames;
  out["frames_with_moving_pixels"] = s.frames_with_mask;
  out["mean_masked_share"] = s.MeanShare();
  out["detections_by_level"] = s.detections_by_level;
  out["high_level_regions"] = s.high_regions;
  out["high_level_confirmed_by_geometry"] = s.high_confirmed;
  out["high_level_static_by_geometry"] = s.high_static;
  out["medium_level_moving"] = s.medium_moving;
  out["medium_level_static"] = s.medium_static;
  out["geometric_regions_outside_detections"] = s.geometric_only;
  out["geometric_regions_outlined"] = s.geometric_outlined;
  out["unclaimed_outline_min_px"] = options.unclaimed_outline_min_px;  // as resolved
  out["depth_check_seed_pixels"] = s.depth_seeds;
  out["flow_check_seed_points"] = s.flow_seeds;
  return out;
}

json MaskQualityJson(const MaskScore& score) {
  return {{"truth", "masks.txt"},
          {"frames", score.frames},
          {"precision", score.Precision()},
          {"recall", score.Recall()},
          {"iou", score.Iou()},
          {"mean_frame_iou", score.MeanFrameIou()}};
}

}  // namespace

json MapJson(const MapFigures& map, const BuildConfig& config) {
  const MapperOptions& mapping = config.mapping;
  return {{"voxel_leaf_m", mapping.voxel.leaf_size},
          {"points_fused", map.statistics.points},
          {"voxels", map.voxels},
          {"voxels_written", map.voxels_written},
          {"voxels_removed_seen_through", map.cleaning.seen_through},
          {"voxels_removed_seen_through_views", map.cleaning.seen_through_views},
          {"voxels_removed_outliers", map.cleaning.outliers},
          {"clear_seen_through_views", mapping.cleaning.clear_seen_through_views},
          {"clear_seen_through", mapping.cleaning.clear_seen_through && mapping.occupancy.enabled},
          {"outlier_removal", mapping.cleaning.outlier_removal},
          {"min_points_per_voxel", mapping.voxel.min_points},
          {"voxels_out_of_range", map.voxels_out_of_range},
          {"voxel_table_mib", map.voxel_table_mib},
          {"octomap_enabled", mapping.occupancy.enabled},
          {"octomap_resolution_m", mapping.occupancy.resolution},
          {"octomap_leaves", map.octomap_leaves},
          {"octomap_points_out_of_range", map.octomap_points_out_of_range},
          {"octomap_occupied_leaves", map.octomap_occupied_leaves}};
}

json MeshJson(const std::optional<MeshFigures>& mesh, const MapMeshOptions& options) {
  if (!mesh) return nullptr;
  return {{"file", mesh->file},
          {"voxel_m", options.voxel},
          {"voxels", mesh->voxels},
          {"vertices", mesh->vertices},
          {"triangles", mesh->triangles},
          {"method",
           "exposed faces of the occupied voxels, shared corners colored by the voxels meeting "
           "there"}};
}

std::vector<double> RowMajor(const Eigen::Isometry3d& transform) {
  const Eigen::Matrix4d& m = transform.matrix();
  std::vector<double> values;
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) values.push_back(m(r, c));
  }
  return values;
}

json FloorJson(const FloorPlane& floor) {
  return {{"source", floor.source},
          {"up_in_poses_frame", {floor.up.x(), floor.up.y(), floor.up.z()}},
          {"offset_in_poses_frame_m", floor.offset},
          {"tilt_to_cameras_up_deg", floor.tilt_to_cameras_deg},
          {"plane_voxels", floor.inliers}};
}

namespace {

// The files the build wrote, for report.html's links.
json OutputsJson(const BuildResult& result, const BuildConfig& config) {
  json files = {"map.ply", "map.pcd"};
  if (config.mapping.occupancy.enabled) files.insert(files.end(), {"map.bt", "map.ot"});
  files.insert(files.end(), {"trajectory.txt", "keyframes.txt"});
  if (result.grid) files.insert(files.end(), {"grid.pgm", "grid.yaml"});
  if (result.mesh) files.push_back(result.mesh->file);
  files.insert(files.end(), {"config.yaml", "report.json"});
  for (const SegmentSummary& segment : result.segments) {
    if (!segment.in_map) files.push_back(fmt::format("segments/{}/", segment.id));
  }
  return files;
}

}  // namespace

json GridJson(const OccupancyGrid& grid) {
  return {{"files", {"grid.pgm", "grid.yaml"}},
          {"width", grid.width},
          {"height", grid.height},
          {"resolution_m", grid.resolution},
          {"origin_m", {grid.origin.x(), grid.origin.y()}},
          {"band_m", {grid.min_height, grid.max_height}},
          {"cells",
           {{"free", grid.Count(kGridFree)},
            {"occupied", grid.Count(kGridOccupied)},
            {"unknown", grid.Count(kGridUnknown)},
            {"occupied_unconfirmed_made_unknown", grid.unconfirmed_cells},
            {"occupied_without_cloud_points_in_band", grid.unsupported_cells},
            {"occupied_by_a_neighbours_surface_spill", grid.spilled_cells},
            {"start_cell_made_free", grid.start_made_free},
            {"free_with_an_unseen_layer_made_unknown", grid.unseen_layer_cells}}},
          {"frame",
           fmt::format(
               "x, y in the floor plane, z up from the floor, origin on the floor under the first "
               "camera, x along its view (the map frame itself when {}=floor)",
               OptionKey(&MapFrameOptions::frame))},
          {"world_from_map", RowMajor(grid.world_from_grid)},
          {"floor",
           {{"source", grid.floor.source},
            {"tilt_to_cameras_up_deg", grid.floor.tilt_to_cameras_deg},
            {"plane_voxels", grid.floor.inliers}}}};
}

namespace {

void AddTrajectoryError(const EvaluationFigures& evaluation, const BuildConfig& config,
                        json* report) {
  (*report)["trajectory_error"] = nullptr;
  if (!evaluation.ate) {
    (*report)["trajectory_error_note"] = evaluation.trajectory_note;
    return;
  }
  json error = {{"ate_m", StatisticsJson(evaluation.ate->translation)},
                {"ate_max_time_difference_s", config.ate.max_time_difference}};
  if (evaluation.rpe) {
    error["rpe_delta_s"] = config.rpe.delta;
    error["rpe_translation_m"] = StatisticsJson(evaluation.rpe->translation);
    error["rpe_rotation_deg"] = StatisticsJson(evaluation.rpe->rotation);
  } else {
    error["rpe_note"] = evaluation.rpe_note;
  }
  (*report)["trajectory_error"] = error;
}

void AddMapQuality(const BuildResult& result, json* report) {
  const EvaluationFigures& evaluation = result.evaluation;
  if (evaluation.static_groundtruth.empty()) return;
  if (!evaluation.map_quality) {
    (*report)["map_quality"] = nullptr;
    (*report)["map_quality_note"] = evaluation.map_quality_note;
    return;
  }
  const MapQuality& quality = *evaluation.map_quality;
  (*report)["map_quality"] = {{"groundtruth", evaluation.static_groundtruth},
                              {"aligned_by", AlignedBy(result.poses)},
                              {"map_points", quality.map_points},
                              {"groundtruth_points", quality.groundtruth_points},
                              {"accuracy_mean_m", quality.accuracy_mean},
                              {"accuracy_median_m", quality.accuracy_median},
                              {"completeness", quality.completeness},
                              {"ghost_share", quality.ghost_share},
                              {"on_surface_share", quality.on_surface_share},
                              {"on_surface_distance_m", MapQualityOptions().surface_distance}};
  if (!evaluation.grid_quality) return;
  const GridQuality& grid = *evaluation.grid_quality;
  (*report)["grid_quality"] = {
      {"observed_cells", grid.observed_cells},
      {"agreement", grid.agreement},
      {"occupied_cells", grid.occupied_cells},
      {"occupied_without_static_truth", grid.false_occupied},
      {"of_those_on_moving_objects_paths",
       evaluation.moving_objects_known ? json(grid.false_occupied_on_paths) : json(nullptr)},
      {"path_margin_m", grid.path_margin_m},
      {"free_where_truth_occupied", grid.missed_occupied}};
}

}  // namespace

json ReportJson(const BuildResult& result, const BuildConfig& config) {
  json report;
  report["stillmap_version"] = STILLMAP_VERSION;
  report["sequence"] = result.sequence_dir;
  report["poses"] = PoseSourceName(result.poses);
  if (result.given_poses.given()) report["given_poses"] = GivenPosesJson(result.given_poses);
  report["map_frame"] = MapFrameJson(result.map_frame, result.poses);
  report["command"] = result.command_line.empty() ? json(nullptr) : json(result.command_line);
  report["outputs"] = OutputsJson(result, config);
  report["camera"] = CameraJson(result.camera);
  report["frames"] = FramesJson(result.frames);
  report["keyframes"] = KeyframesJson(result, config);
  report["dynamic_share"] = result.masking.statistics.MeanShare();
  report["masking"] = MaskingJson(result.masking);
  if (result.masking.statistics.score) {
    report["mask_quality"] = MaskQualityJson(*result.masking.statistics.score);
    if (result.masking.statistics.score_while_still) {
      json still = MaskQualityJson(*result.masking.statistics.score_while_still);
      still["truth"] = "masks.txt, frames in which objects.txt has an object standing still";
      report["mask_quality"]["while_still"] = still;
    }
  }
  report["map"] = MapJson(result.map, config);
  report["mesh"] = MeshJson(result.mesh, config.mesh);
  if (result.grid) {
    report["grid"] = GridJson(*result.grid);
  } else {
    report["grid"] = nullptr;
    report["grid_note"] =
        config.grid.enabled
            ? fmt::format("not written: the OctoMap is off ({})",
                          OptionKey(&OccupancyMapOptions::enabled))
            : fmt::format("not written: {}=false", OptionKey(&GridOptions::enabled));
  }
  if (result.tracking) report["tracking"] = TrackingJson(*result.tracking, config.tracking);
  if (!result.segments.empty()) {
    report["segments"] = SegmentsJson(result.segments);
    const SegmentLinkFigures& links = result.segment_links;
    report["segment_links"] = {{"candidates", links.candidates},
                               {"verified", links.verified},
                               {"too_far", links.too_far},
                               {"loops", links.loops},
                               {"settles", links.settles}};
  }
  report["warnings"] = result.warnings;
  report["threads"] = result.threads;
  report["timing"] = RunTimingJson(result);
  if (result.poses == PoseSource::kGroundTruth) {
    report["trajectory_error"] = nullptr;
    report["trajectory_error_note"] = result.evaluation.trajectory_note;
  } else {
    AddTrajectoryError(result.evaluation, config, &report);
  }
  AddMapQuality(result, &report);
  report["renders"] = result.renders ? json(*result.renders) : json(nullptr);
  return report;
}

namespace {

// What the build wrote, by name (a folder with its file count), from the output folder itself.
std::string WrittenLine(const std::string& output_dir) {
  std::vector<std::string> written;
  std::error_code error;
  for (const std::string& name : BuildOutputNames()) {
    const std::filesystem::path path = std::filesystem::path(output_dir) / name;
    if (name.back() == '/' && std::filesystem::is_directory(path, error)) {
      const auto files = std::distance(std::filesystem::directory_iterator(path, error),
                                       std::filesystem::directory_iterator());
      written.push_back(fmt::format("{} ({} files)", name, files));
    } else if (std::filesystem::is_regular_file(path, error)) {
      written.push_back(name);
    }
  }
  return fmt::format("wrote {}", fmt::join(written, ", "));
}

}  // namespace

std::vector<std::string> SummaryLines(const BuildResult& result, const std::string& output_dir) {
  std::vector<std::string> lines;
  lines.push_back(fmt::format(
      "{} of {} frames tracked, {} fused, {} map points, {:.1f} frames/s, peak memory {:.0f} MiB; "
      "outputs in {}",
      result.frames.tracked, result.frames.pairs_used, result.frames.fused,
      result.map.voxels_written, result.frames_per_second, result.peak_memory_mib, output_dir));
  const GivenPoseFigures& given = result.given_poses;
  if (given.given()) {
    const size_t carried = result.tracking ? result.tracking->statistics.carried : 0;
    lines.push_back(fmt::format(
        "poses: {}, {}; {} frames without a given pose", given.description,
        given.use == "prior" ? fmt::format("the tracker's prior ({} frames carried)", carried)
                             : std::string("the map's poses"),
        given.without_pose()));
  }
  if (result.tracking && result.tracking->planar_motion_applied) {
    const PlanarMotion& plane = *result.tracking->planar_motion;
    lines.push_back(fmt::format(
        "poses put on the camera's plane of motion ({}): the tracked ones kept to it within {:.0f} "
        "mm of height and {:.2f} degrees of tilt (median deviations)",
        OptionKey(&TrackerOptions::planar_motion), plane.height_median_deviation_m * 1e3,
        plane.tilt_median_deviation_deg));
    const std::optional<FloorUpFigures>& floor = result.tracking->planar_floor;
    if (floor && floor->taken) {
      lines.push_back(fmt::format(
          "the camera's tilt taken from the floor {} of {} keyframes saw: {:.2f} degrees from the "
          "tracked poses' (normals within {:.2f} degrees of their median)",
          floor->keyframes_seeing_floor, floor->keyframes_read, floor->change_deg,
          floor->spread_deg));
    }
  }
  size_t apart_frames = 0, apart_segments = 0;
  for (const SegmentSummary& segment : result.segments) {
    if (segment.in_map) continue;
    apart_frames += segment.frames;
    ++apart_segments;
  }
  if (apart_segments > 0) {
    lines.push_back(fmt::format(
        "{} more frames tracked in {} map segment(s) that could not be placed in the map: "
        "written apart under segments/ (warnings below)",
        apart_frames, apart_segments));
  }
  if (result.AteRmse()) {
    lines.push_back(
        fmt::format("trajectory vs ground truth: ATE RMSE {:.1f} mm (report.json has RPE)",
                    *result.AteRmse() * 1e3));
  }
  lines.push_back(
      fmt::format("keyframes: {} fused, {} invalid, {} redundant, {} seen before; mean masked "
                  "share {:.1f} %",
                  result.frames.fused, result.selection.invalid, result.selection.redundant,
                  result.selection.seen_before, 100.0 * result.masking.statistics.MeanShare()));
  if (result.masking.semantics) {
    lines.push_back(fmt::format("detector: {} (models in {}, found through {})",
                                result.masking.detector, result.masking.models_dir,
                                result.masking.models_found_by));
  }
  if (const std::optional<MaskScore>& score = result.masking.statistics.score) {
    lines.push_back(fmt::format("masks vs masks/: precision {:.3f}, recall {:.3f}, IoU {:.3f}",
                                score->Precision(), score->Recall(), score->Iou()));
  }
  if (const std::optional<MapQuality>& quality = result.evaluation.map_quality) {
    lines.push_back(fmt::format(
        "map vs static_gt.ply: accuracy median {:.1f} mm, mean {:.1f} mm; within {:.0f} cm {:.1f} "
        "%; completeness {:.1f} %; ghost share {:.2f} %",
        quality->accuracy_median * 1e3, quality->accuracy_mean * 1e3,
        MapQualityOptions().surface_distance * 1e2, 100.0 * quality->on_surface_share,
        100.0 * quality->completeness, 100.0 * quality->ghost_share));
  }
  lines.push_back(WrittenLine(output_dir));
  if (!result.warnings.empty()) {
    lines.push_back(
        fmt::format("{} warning(s) below (also in report.json)", result.warnings.size()));
  }
  lines.push_back(
      fmt::format("the run at a glance: {}",
                  (std::filesystem::path(output_dir) / "report.html").lexically_normal().string()));
  return lines;
}

}  // namespace stillmap
