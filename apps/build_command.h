// `stillmap build`: its options, and the one library call (RunBuild) they become.
#pragma once

#include <CLI/CLI.hpp>
#include <string>
#include <vector>

#include "command_steps.h"
#include "stillmap/pipeline/build_request.h"

namespace stillmap_app {

struct BuildCommand {
  stillmap::BuildRequest request;
  ConfigArguments config;
  // The run settings as given on the command line; each overrides run.* only when given.
  std::string poses, detector, models;
  int threads = 2;
  std::vector<std::string> topics;
  std::string groundtruth;
  bool quiet = false;
  bool verbose = false;
  CLI::App* command = nullptr;

  void Add(CLI::App& app);
  void Run();
  // A build killed while swapping its outputs in is completed first, even when this one is then
  // refused for a bad option.
  void RecoverEarlierSwap() const;

 private:
  void AddRunOptions();
  void ApplyTopics();
  void ApplyRunOptions();
};

}  // namespace stillmap_app
