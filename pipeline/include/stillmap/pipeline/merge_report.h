// The report of a merge, written from its one typed result: report.json (and through it
// report.html) and the terminal summary.
#pragma once

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "stillmap/pipeline/merge_request.h"
#include "stillmap/pipeline/merge_result.h"

namespace stillmap {

// report.json of a merge.
nlohmann::json MergeReportJson(const MergeResult& result, const MergeRequest& request);

// The end-of-run summary, one line each.
std::vector<std::string> MergeSummaryLines(const MergeResult& result,
                                           const std::string& output_dir);

}  // namespace stillmap
