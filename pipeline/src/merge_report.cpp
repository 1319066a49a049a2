// report.json and the terminal summary of `stillmap merge`.
#include "stillmap/pipeline/merge_report.h"

#include <fmt/format.h>

#include <filesystem>

#include "report_parts.h"

namespace stillmap {
namespace {

using nlohmann::json;

json SessionJson(const MergeSessionFigures& session) {
  json out = {{"name", session.name},
              {"folder", session.dir},
              {"sequence", session.sequence},
              {"keyframes", session.keyframes},
              {"keyframes_fused", session.keyframes_fused},
              {"keyframes_redundant", session.keyframes_redundant},
              {"joined", session.joined},
              {"fusion_order", session.fusion_order},
              {"placement_m", session.placement_m},
              {"placement_deg", session.placement_deg},
              {"pose_graph_largest_move_m", session.graph_move_m},
              {"pose_graph_largest_move_deg", session.graph_move_deg},
              {"trajectory", session.trajectory_file}};
  if (session.ate) {
    out["ate"] = StatisticsJson(session.ate->translation);
  } else if (session.joined) {
    out["ate_note"] = session.ate_note;
  }
  return out;
}

json PairJson(const MergePairFigures& pair) {
  return {{"sessions", {pair.session_a, pair.session_b}},
          {"candidates", pair.candidates},
          {"verified", pair.verified},
          {"agreeing", pair.agreeing},
          {"joined", pair.joined}};
}

}  // namespace

json MergeReportJson(const MergeResult& result, const MergeRequest& request) {
  const BuildConfig& config = request.config;
  json sessions = json::array(), pairs = json::array();
  for (const MergeSessionFigures& session : result.sessions)
    sessions.push_back(SessionJson(session));
  for (const MergePairFigures& pair : result.pairs) pairs.push_back(PairJson(pair));
  json report = {{"command", request.command_line},
                 {"kind", "merge"},
                 {"sessions", sessions},
                 {"pairs", pairs},
                 {"pose_graph",
                  {{"keyframes", result.graph_nodes},
                   {"links", result.graph_links},
                   {"initial_cost", result.graph_initial_cost},
                   {"final_cost", result.graph_final_cost},
                   {"converged", result.graph_converged}}},
                 {"map", MapJson(result.map, config)},
                 {"revisit_cells_left_out", result.revisit_cells_left_out},
                 {"map_frame",
                  {{"name", result.map_frame.name},
                   {"description", result.map_frame.description},
                   {"of_session", result.sessions.front().name},
                   {"floor_found", result.map_frame.floor_found},
                   {"floor", FloorJson(result.map_frame.floor)}}},
                 {"mesh", MeshJson(result.mesh, config.mesh)},
                 {"timing",
                  {{"wall_s", result.wall_time_s},
                   {"links_ms", result.links_ms},
                   {"pose_graph_ms", result.graph_ms},
                   {"fuse_ms", result.fuse_ms},
                   {"map_cleaning_ms", result.timings.map_cleaning_ms},
                   {"grid_ms", result.timings.grid_ms},
                   {"mesh_ms", result.timings.mesh_ms},
                   {"write_ms", result.timings.write_ms},
                   {"peak_memory_mib", result.peak_memory_mib}}},
                 {"renders", result.renders},
                 {"warnings", result.warnings}};
  if (result.grid) report["grid"] = GridJson(*result.grid);
  if (const std::optional<MapQuality>& quality = result.map_quality) {
    report["map_quality"] = {{"accuracy_mean_m", quality->accuracy_mean},
                             {"accuracy_median_m", quality->accuracy_median},
                             {"completeness", quality->completeness},
                             {"ghost_share", quality->ghost_share},
                             {"on_surface_share", quality->on_surface_share},
                             {"map_points", quality->map_points},
                             {"groundtruth", "static_gt.ply of the first session's sequence"}};
  }
  if (result.ate_joint) {
    report["ate_all_sessions"] = StatisticsJson(*result.ate_joint);
    report["ate_all_sessions"]["alignment"] =
        "every joined session's trajectory_<session>.txt against its ground truth, aligned by "
        "one rigid transform (Horn, no scale)";
  }
  return report;
}

std::vector<std::string> MergeSummaryLines(const MergeResult& result,
                                           const std::string& output_dir) {
  std::vector<std::string> lines;
  size_t joined = 0;
  for (const MergeSessionFigures& session : result.sessions) joined += session.joined ? 1 : 0;
  lines.push_back(fmt::format(
      "{} of {} sessions merged ({} keyframes, {} links between sessions), {} map points, "
      "{:.1f} s, peak memory {:.0f} MiB; outputs in {}",
      joined, result.sessions.size(), result.graph_nodes, result.graph_links,
      result.map.voxels_written, result.wall_time_s, result.peak_memory_mib, output_dir));
  for (const MergePairFigures& pair : result.pairs) {
    lines.push_back(fmt::format("  {} ~ {}: {} verified links, {} agreeing{}", pair.session_a,
                                pair.session_b, pair.verified, pair.agreeing,
                                pair.joined ? ", joined" : ", not joined"));
  }
  for (const MergeSessionFigures& session : result.sessions) {
    if (session.ate) {
      lines.push_back(fmt::format("  {}: ATE RMSE {:.1f} mm in the merged frame", session.name,
                                  session.ate->translation.rmse * 1e3));
    }
  }
  if (result.ate_joint) {
    lines.push_back(fmt::format("all sessions vs ground truth, one alignment: ATE RMSE {:.1f} mm",
                                result.ate_joint->rmse * 1e3));
  }
  if (const std::optional<MapQuality>& quality = result.map_quality) {
    lines.push_back(fmt::format(
        "map vs static_gt.ply: accuracy median {:.1f} mm; completeness {:.1f} %; ghost share "
        "{:.2f} %",
        quality->accuracy_median * 1e3, 100.0 * quality->completeness,
        100.0 * quality->ghost_share));
  }
  if (!result.warnings.empty()) {
    lines.push_back(
        fmt::format("{} warning(s) below (also in report.json)", result.warnings.size()));
  }
  lines.push_back(
      fmt::format("the merge at a glance: {}",
                  (std::filesystem::path(output_dir) / "report.html").lexically_normal().string()));
  return lines;
}

}  // namespace stillmap
