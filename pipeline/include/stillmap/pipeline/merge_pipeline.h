// `stillmap merge`: the session records of several builds of one place in, one map out. Library
// code, so that tests drive it exactly as the command line does. The steps live in pipeline/src:
// the sessions (merge_sessions), the links between them (merge_links), the pose graph
// (merge_graph), the fusion (merge_fusion), the evaluation (merge_evaluation), and here the
// controller that joins them, the files and the report (merge_report.h).
#pragma once

#include <string>
#include <vector>

#include "stillmap/pipeline/merge_request.h"
#include "stillmap/pipeline/merge_result.h"

namespace stillmap {

// Every top-level name a merge writes besides the trajectory_<session>.txt files.
const std::vector<std::string>& MergeOutputNames();

// Runs the merge. Throws InputError for bad input (a folder without a session record, a damaged
// record, bad options) and when no session can be joined to the first (exit 2); a session that
// shares no verified place with the others is left out with a warning naming it. The outputs are
// staged aside and swapped in whole (io/output_files.h).
MergeResult RunMerge(const MergeRequest& request);

}  // namespace stillmap
