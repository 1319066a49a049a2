// The report of a build, written from its one typed result: report.json (and through it
// report.html) and the terminal summary.
#pragma once

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "stillmap/pipeline/build_result.h"
#include "stillmap/pipeline/config.h"

namespace stillmap {

// report.json: every figure of `result`, with the options of `config` that explain them.
nlohmann::json ReportJson(const BuildResult& result, const BuildConfig& config);

// The end-of-run summary, one line each (frames, speed, ATE, keyframes, masks, map quality, the
// files in output_dir, how many warnings follow, and the path of report.html).
std::vector<std::string> SummaryLines(const BuildResult& result, const std::string& output_dir);

}  // namespace stillmap
