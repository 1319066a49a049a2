// What `stillmap merge` is asked to do: the sessions, the output folder and the configuration,
// whose run.threads says how the run is carried out.
#pragma once

#include <string>
#include <vector>

#include "stillmap/pipeline/config.h"

namespace stillmap {

struct MergeRequest {
  std::vector<std::string> session_dirs;  // build output folders; the first sets the map frame
  std::string output_dir;
  BuildConfig config;  // the first session's config.yaml, with --set applied; run.threads
  bool show_progress = false;
  std::string command_line;  // as typed, for the report

  int threads() const { return config.run.threads; }
};

}  // namespace stillmap
