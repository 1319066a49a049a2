// What a `stillmap merge` run did, as one typed value: its report.json, report.html and the
// terminal summary are written from it (merge_report.h).
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "stillmap/io/evaluation.h"
#include "stillmap/pipeline/build_result.h"

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

}  // namespace stillmap
