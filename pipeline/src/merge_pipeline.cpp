#include "stillmap/pipeline/merge_pipeline.h"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <numeric>

#include "map_outputs.h"
#include "merge_evaluation.h"
#include "merge_fusion.h"
#include "merge_graph.h"
#include "merge_links.h"
#include "merge_sessions.h"
#include "stillmap/io/cloud_files.h"
#include "stillmap/io/cpu_usage.h"
#include "stillmap/io/error.h"
#include "stillmap/io/image_io.h"
#include "stillmap/io/option_names.h"
#include "stillmap/io/output_files.h"
#include "stillmap/io/timing.h"
#include "stillmap/io/trajectory.h"
#include "stillmap/mapping/map_quality.h"
#include "stillmap/mapping/revisit_cells.h"
#include "stillmap/pipeline/merge_report.h"
#include "stillmap/pipeline/progress.h"
#include "stillmap/pipeline/report_html.h"
#include "stillmap/viewer/renders.h"

namespace stillmap {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

// The merged map may not be written into one of the sessions' folders: it would replace them.
void CheckOutputApart(const MergeRequest& request) {
  std::error_code error;
  const fs::path output = fs::weakly_canonical(request.output_dir, error);
  for (const std::string& dir : request.session_dirs) {
    if (!error && fs::weakly_canonical(dir, error) == output) {
      throw InputError("-o " + request.output_dir + ": the output folder is the session " + dir +
                       "; write the merged map elsewhere");
    }
  }
}

// The links of every pair of sessions.
std::vector<PairLinks> LinkSessions(const std::vector<MergeSession>& sessions,
                                    const BuildConfig& config, MergeResult* result) {
  std::vector<SessionPlaces> places;
  places.reserve(sessions.size());
  for (const MergeSession& session : sessions) {
    places.emplace_back(session.record(), config.tracking.loops.place);
  }
  std::vector<PairLinks> pairs;
  for (size_t a = 0; a < sessions.size(); ++a) {
    for (size_t b = a + 1; b < sessions.size(); ++b) {
      pairs.push_back(
          FindLinks(places[a], places[b], static_cast<int>(a), static_cast<int>(b), config.merge));
      const PairLinks& pair = pairs.back();
      result->pairs.push_back({sessions[a].name, sessions[b].name, pair.candidates, pair.verified,
                               static_cast<int>(pair.agreeing.size()), pair.joined});
    }
  }
  return pairs;
}

// The sessions' figures from the joined poses; warns of every session left out. Throws
// InputError when none could be joined to the first.
void DescribeSessions(const std::vector<MergeSession>& sessions, const JoinedSessions& joined,
                      const MergeOptions& options, MergeResult* result) {
  std::vector<std::string> left_out;
  for (size_t s = 0; s < sessions.size(); ++s) {
    MergeSessionFigures figures;
    figures.name = sessions[s].name;
    figures.dir = sessions[s].dir;
    figures.sequence = sessions[s].record().sequence;
    figures.keyframes = sessions[s].record().keyframes.size();
    figures.joined = joined.included[s];
    if (!figures.joined) left_out.push_back(sessions[s].name);
    const Eigen::Isometry3d& placement = joined.first_from_session[s];
    figures.placement_m = placement.translation().norm();
    figures.placement_deg = RotationAngleDeg(placement);
    const std::vector<Eigen::Isometry3d>& solved = joined.first_from_keyframe[s];
    for (size_t k = 0; k < solved.size(); ++k) {
      const Eigen::Isometry3d move =
          (placement * sessions[s].record().keyframes[k].map_from_camera).inverse() * solved[k];
      figures.graph_move_m = std::max(figures.graph_move_m, move.translation().norm());
      figures.graph_move_deg = std::max(figures.graph_move_deg, RotationAngleDeg(move));
    }
    result->sessions.push_back(figures);
  }
  if (left_out.size() + 1 == sessions.size()) {
    std::string links;
    constexpr size_t kPairsNamed = 10;  // of hundreds of sessions, the message names a few pairs
    for (size_t i = 0; i < result->pairs.size() && i < kPairsNamed; ++i) {
      const MergePairFigures& pair = result->pairs[i];
      links += fmt::format("; {} ~ {}: {} verified links, {} agreeing", pair.session_a,
                           pair.session_b, pair.verified, pair.agreeing);
    }
    if (result->pairs.size() > kPairsNamed) links += "; ...";
    throw InputError(fmt::format(
        "no session shares a verified place with the first, {} ({}), so nothing can be merged "
        "(a pair is joined by {}={} agreeing links{}); were they recorded in the same place?",
        sessions[0].name, sessions[0].dir, OptionKey(options, options.min_links), options.min_links,
        links));
  }
  for (const std::string& name : left_out) {
    result->warnings.push_back(
        "session '" + name + "' shares no verified place with the sessions joined to the first, " +
        sessions[0].name + ": it is left out of the merged map (its links: report.json, pairs)");
  }
}

// trajectory_<session>.txt of every joined session, in the merged frame; returns them (empty
// for sessions left out).
std::vector<Trajectory> WriteTrajectories(const std::vector<MergeSession>& sessions,
                                          const JoinedSessions& joined,
                                          const MapFrameFigures& frame, OutputSet& outputs,
                                          MergeResult* result) {
  std::vector<Trajectory> trajectories(sessions.size());
  for (size_t s = 0; s < sessions.size(); ++s) {
    if (!joined.included[s]) continue;
    std::vector<StampedPose> poses;
    for (const StampedPose& pose : sessions[s].trajectory.poses()) {
      poses.push_back({pose.time, CorrectedPose(sessions[s].record(), joined.first_from_keyframe[s],
                                                pose.time, pose.world_from_camera)});
    }
    const std::string name = "trajectory_" + sessions[s].name + ".txt";
    trajectories[s] = Trajectory(std::move(poses));
    trajectories[s].WriteTum(outputs.TemporaryPath(name),
                             "stillmap merge: session " + sessions[s].name +
                                 " (camera-to-map, every tracked frame); map frame " + frame.name +
                                 " of session " + sessions[0].name);
    result->sessions[s].trajectory_file = name;
  }
  return trajectories;
}

MergeFusionOptions FusionOptionsOf(const MergeRequest& request) {
  const BuildConfig& config = request.config;
  MergeFusionOptions options{config.mapping, config.selection.revisit, request.show_progress};
  // Between sessions a keyframe is redundant by the merge's share, not the build's.
  options.revisit.max_seen_share = config.merge.max_seen_share;
  options.mapping.in_background = options.mapping.in_background && request.threads() > 1;
  return options;
}

void TakeFusionFigures(const MergeFusion& fusion, MergeResult* result) {
  for (size_t s = 0; s < result->sessions.size(); ++s) {
    result->sessions[s].fusion_order = fusion.fusion_order[s];
    result->sessions[s].keyframes_fused = fusion.keyframes_fused[s];
    result->sessions[s].keyframes_redundant = fusion.keyframes_redundant[s];
  }
  result->revisit_cells_left_out = fusion.revisit_cells_left_out;
}

void TakeEvaluation(MergeEvaluation evaluation, MergeResult* result) {
  for (size_t s = 0; s < result->sessions.size(); ++s) {
    result->sessions[s].ate = std::move(evaluation.ate[s]);
    if (!evaluation.ate_notes[s].empty()) result->sessions[s].ate_note = evaluation.ate_notes[s];
  }
  result->ate_joint = evaluation.ate_joint;
  result->map_quality = evaluation.map_quality;
}

// The merged map's frame: the first session's, with its floor.
MapFrameFigures FirstSessionFrame(const MergeSession& first) {
  const SessionMapFrame& frame = first.record().map_frame;
  MapFrameFigures out;
  out.name = frame.name;
  out.description = frame.description + "; sessions merged into it (stillmap merge)";
  out.floor.up = frame.floor_up;
  out.floor.offset = frame.floor_offset;
  out.floor.source = frame.floor_source;
  out.floor_found = frame.floor_found;
  out.map_from_floor = frame.map_from_floor;
  return out;
}

std::vector<VoxelPoint> WriteMergedMap(FinishedMap map, const std::vector<MergeSession>& sessions,
                                       const MergeRequest& request, OutputSet& outputs,
                                       MergeResult* result) {
  const BuildConfig& config = request.config;
  const Clock::time_point clean_start = Clock::now();
  const MapCleaningResult cleaning = map.CleanCloud(config.mapping.cleaning);
  result->timings.map_cleaning_ms = MillisecondsSince(clean_start);
  result->map = MapFiguresOf(map, cleaning);
  std::vector<VoxelPoint> cloud = map.TakeCloudPoints();
  if (cloud.size() < static_cast<size_t>(config.mapping.min_map_points)) {
    throw std::runtime_error(fmt::format(
        "the merged map is nearly empty ({} points, fewer than {}={})", cloud.size(),
        OptionKey(config, config.mapping.min_map_points), config.mapping.min_map_points));
  }
  result->map_frame = FirstSessionFrame(sessions[0]);
  const Eigen::Vector3d start =
      sessions[0].record().keyframes.front().map_from_camera.translation();
  const Clock::time_point grid_start = Clock::now();
  // The merge's mapper keeps no grid views: its grid makes no unseen-layer check.
  result->grid =
      ProjectMapGrid(map, cloud, start, result->map_frame, config.grid, {}, request.threads() > 1);
  result->timings.grid_ms = MillisecondsSince(grid_start);
  const MapFileOptions files{config.mesh, config.mapping.voxel.leaf_size, request.threads() > 1};
  result->mesh =
      WriteMapFiles(map, &cloud, result->map_frame, result->grid, files, outputs, &result->timings);
  return cloud;
}

void WriteMergeRenders(std::vector<VoxelPoint> cloud, const std::vector<MergeSession>& sessions,
                       const JoinedSessions& joined, const MergeRequest& request,
                       OutputSet& outputs, MergeResult* result) {
  if (!request.config.render.enabled) return;
  RenderInput input;
  input.cloud = std::move(cloud);
  input.grid = result->grid;
  for (size_t s = 0; s < sessions.size(); ++s) {
    for (const Eigen::Isometry3d& pose : joined.first_from_keyframe[s]) {
      input.keyframes.push_back(pose);
      input.trajectory.push_back(pose);
    }
  }
  input.title = fmt::format("{} sessions merged", joined.first_from_keyframe.size());
  for (const auto& [name, image] : RenderViews(input, request.config.render)) {
    WriteImage(outputs.TemporaryPath("renders/" + name), image, ".png");
    result->renders.push_back("renders/" + name);
  }
}

}  // namespace

const std::vector<std::string>& MergeOutputNames() {
  static const std::vector<std::string> kNames = {
      "map.ply",  "map.pcd",  "map.bt",   "map.ot",   "grid.pgm",    "grid.yaml",   "mesh.glb",
      "mesh.obj", "mesh.mtl", "mesh.ply", "renders/", "config.yaml", "report.json", "report.html"};
  return kNames;
}

MergeResult RunMerge(const MergeRequest& request) {
  const Clock::time_point start = Clock::now();
  request.config.Validate();
  if (request.session_dirs.size() < 2) {
    throw InputError("stillmap merge needs at least two session folders");
  }
  CheckOutputApart(request);
  MergeResult result;
  std::vector<MergeSession> sessions = OpenSessions(request.session_dirs);

  Clock::time_point step = Clock::now();
  const std::vector<PairLinks> pairs = LinkSessions(sessions, request.config, &result);
  result.links_ms = MillisecondsSince(step);
  step = Clock::now();
  const JoinedSessions joined =
      JoinSessions(sessions, pairs, request.config.merge, request.config.tracking.loops.pose_graph);
  result.graph_ms = MillisecondsSince(step);
  result.graph_links = joined.links;
  result.graph_initial_cost = joined.initial_cost;
  result.graph_final_cost = joined.final_cost;
  result.graph_converged = joined.converged;
  for (const auto& poses : joined.first_from_keyframe) result.graph_nodes += poses.size();
  DescribeSessions(sessions, joined, request.config.merge,
                   &result);  // throws when nothing can be joined

  // Locks the output folder and stages the outputs aside until all are written.
  std::vector<std::string> names = MergeOutputNames();
  for (const MergeSession& session : sessions) {
    names.push_back("trajectory_" + session.name + ".txt");
  }
  OutputSet outputs(request.output_dir, "merge", names);
  if (!outputs.recovery_note().empty()) result.warnings.push_back(outputs.recovery_note());

  step = Clock::now();
  MergeFusion fusion = FuseSessions(sessions, joined, FusionOptionsOf(request));
  result.fuse_ms = MillisecondsSince(step);
  TakeFusionFigures(fusion, &result);
  FinishedMap map = std::move(fusion.map);
  step = Clock::now();
  std::vector<VoxelPoint> cloud =
      WriteMergedMap(std::move(map), sessions, request, outputs, &result);
  const std::vector<Trajectory> trajectories =
      WriteTrajectories(sessions, joined, result.map_frame, outputs, &result);
  WriteText(outputs.TemporaryPath("config.yaml"), ConfigToYaml(request.config), "config.yaml");
  result.timings.write_ms = MillisecondsSince(step);
  result.wall_time_s = SecondsSince(start);
  result.peak_memory_mib = PeakMemoryMib();

  TakeEvaluation(EvaluateMerge(sessions, joined, trajectories, cloud, request.config.ate), &result);
  WriteMergeRenders(std::move(cloud), sessions, joined, request, outputs, &result);
  for (std::string& warning : outputs.SetAsideWarnings({"report.json", "report.html"})) {
    result.warnings.push_back(std::move(warning));
  }
  const nlohmann::json report = MergeReportJson(result, request);
  WriteText(outputs.TemporaryPath("report.json"), report.dump(2) + "\n", "report.json");
  WriteText(outputs.TemporaryPath("report.html"), ReportHtml(report), "report.html");
  outputs.Commit();
  return result;
}

}  // namespace stillmap
