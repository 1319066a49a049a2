// `stillmap merge`: the session records of several builds of one place in, one map out. Library
// code, so that tests drive it exactly as the command line does. The steps live in pipeline/src:
// the sessions (merge_sessions), the links between them (merge_links), the pose graph
// (merge_graph), and here the fusion, the files and the report.
#pragma once

#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "stillmap/io/evaluation.h"
#include "stillmap/pipeline/build_result.h"
#include "stillmap/pipeline/config.h"
#include "stillmap/pipeline/merge_request.h"

namespace stillmap {

struct MergeSessionFigures {
  std::string name, dir, sequence;
  size_t keyframes = 0;
  // Of them, fused, and left out as redundant: more of its view than merge.max_seen_share was
  // seen, at the same depth, by keyframes fused before it.
  size_t keyframes_fused = 0, keyframes_redundant = 0;
  bool joined = false;
  int fusion_order = -1;  // by recording time: a later session's observation wins
  // Where the links placed the session in the first one's frame (identity for the first), and
  // the largest move of one of its keyframes by the pose graph beyond that.
  double placement_m = 0.0, placement_deg = 0.0;
  double graph_move_m = 0.0, graph_move_deg = 0.0;
  std::string trajectory_file;   // trajectory_<name>.txt when joined
  std::optional<AteResult> ate;  // its trajectory in the merged frame, aligned on its own
  std::string ate_note;          // why it was not evaluated
};

struct MergePairFigures {
  std::string session_a, session_b;
  int candidates = 0, verified = 0, agreeing = 0;
  bool joined = false;
};

struct MergeResult {
  std::vector<MergeSessionFigures> sessions;
  std::vector<MergePairFigures> pairs;
  size_t graph_nodes = 0, graph_links = 0;
  size_t revisit_cells_left_out = 0;  // depth cells (16 px) an earlier visit or session saw
  double graph_initial_cost = 0.0, graph_final_cost = 0.0;
  bool graph_converged = false;
  MapFigures map;
  MapFrameFigures map_frame;
  std::optional<OccupancyGrid> grid;
  std::optional<MeshFigures> mesh;
  // All joined sessions' trajectories against their ground truth, aligned by one rigid transform.
  std::optional<ErrorStatistics> ate_joint;
  // Against the first session's static_gt.ply (synthetic sequences), when its sequence has one.
  std::optional<MapQuality> map_quality;
  StageTimings timings;
  double links_ms = 0.0, graph_ms = 0.0, fuse_ms = 0.0;
  double wall_time_s = 0.0, peak_memory_mib = 0.0;
  std::vector<std::string> renders;
  std::vector<std::string> warnings;
};

// Every top-level name a merge writes besides the trajectory_<session>.txt files.
const std::vector<std::string>& MergeOutputNames();

// Runs the merge. Throws InputError for bad input (a folder without a session record, a damaged
// record, bad options) and when no session can be joined to the first (exit 2); a session that
// shares no verified place with the others is left out with a warning naming it. The outputs are
// staged aside and swapped in whole (io/output_files.h).
MergeResult RunMerge(const MergeRequest& request);

// report.json of a merge.
nlohmann::json MergeReportJson(const MergeResult& result, const MergeRequest& request);

// The end-of-run summary, one line each.
std::vector<std::string> MergeSummaryLines(const MergeResult& result,
                                           const std::string& output_dir);

}  // namespace stillmap
