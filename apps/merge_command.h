// `stillmap merge`: its options, and the one library call (RunMerge) they become.
#pragma once

#include <CLI/CLI.hpp>

#include "command_steps.h"
#include "stillmap/pipeline/merge_pipeline.h"

namespace stillmap_app {

struct MergeCommand {
  stillmap::MergeRequest request;
  ConfigArguments config;
  int threads = 2;  // --threads, over run.threads when given
  bool quiet = false;
  CLI::App* command = nullptr;

  void Add(CLI::App& app);
  void Run();
};

}  // namespace stillmap_app
