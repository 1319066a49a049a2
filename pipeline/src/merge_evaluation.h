// A merge measured against the sessions' ground truth, where their sequences have some: each
// joined session's trajectory (on its own, and all together under one rigid alignment) and the
// merged map against the first session's static_gt.ply.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "merge_graph.h"
#include "merge_sessions.h"
#include "stillmap/io/cloud_files.h"
#include "stillmap/io/evaluation.h"
#include "stillmap/io/trajectory.h"
#include "stillmap/mapping/map_quality.h"

namespace stillmap {

struct MergeEvaluation {
  std::vector<std::optional<AteResult>> ate;  // per session, in the merged frame
  std::vector<std::string> ate_notes;         // per session: why it was not evaluated
  std::optional<ErrorStatistics> ate_joint;   // all joined sessions under one alignment
  std::optional<MapQuality> map_quality;      // the merged map, when the first has the truth
};

// `trajectories`: per session, in the merged frame (empty for sessions left out); `cloud`: the
// merged map in the merged frame. Not counted in the merge's speed.
MergeEvaluation EvaluateMerge(const std::vector<MergeSession>& sessions,
                              const JoinedSessions& joined,
                              const std::vector<Trajectory>& trajectories,
                              const std::vector<VoxelPoint>& cloud, const AteOptions& options);

}  // namespace stillmap
