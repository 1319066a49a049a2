// A merge's fusion: every joined session's keyframes fused at their merged poses, in the order
// the sessions were recorded, each depth cell an earlier visit or session saw left out.
#pragma once

#include <vector>

#include "merge_graph.h"
#include "merge_sessions.h"
#include "stillmap/mapping/keyframe_selection.h"
#include "stillmap/mapping/mapper.h"

namespace stillmap {

// What the fusion reads of the request.
struct MergeFusionOptions {
  MapperOptions mapping;   // in_background already off with one thread
  RevisitOptions revisit;  // its max_seen_share is merge.max_seen_share
  bool show_progress = false;
};

struct MergeFusion {
  FinishedMap map;
  // Per session (by its place among the sessions given): its rank in the fusion order (-1: not
  // joined), and its keyframes fused and left out as redundant.
  std::vector<int> fusion_order;
  std::vector<size_t> keyframes_fused, keyframes_redundant;
  size_t revisit_cells_left_out = 0;
};

MergeFusion FuseSessions(std::vector<MergeSession>& sessions, const JoinedSessions& joined,
                         const MergeFusionOptions& options);

}  // namespace stillmap
