// The stillmap command: parses arguments and calls the library. Exit status: 0 success, 1 the run
// failed, 2 bad usage or bad input.
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <cstdio>
#include <string>

#include "build_command.h"
#include "merge_command.h"
#include "stillmap/io/error.h"
#include "stillmap/pipeline/config.h"
#include "stillmap/pipeline/library_messages.h"
#include "tool_commands.h"

namespace {

using stillmap_app::BuildCommand;
using stillmap_app::EvalCommand;
using stillmap_app::InfoCommand;
using stillmap_app::MergeCommand;
using stillmap_app::SynthCommand;
using stillmap_app::ViewCommand;

int Run(int argc, char** argv) {
  spdlog::set_default_logger(spdlog::stderr_color_st("stillmap"));
  spdlog::set_pattern("stillmap: %l: %v");
  stillmap::RegisterConfigKeys();  // the help texts name keys through the registry

  CLI::App app{"stillmap: clean static maps from RGB-D sequences in which people move."};
  app.set_version_flag("--version", std::string("stillmap ") + STILLMAP_VERSION);
  app.require_subcommand(1);
  BuildCommand build;
  for (int i = 0; i < argc; ++i) {
    build.request.command_line += (i > 0 ? " " : "") + std::string(argv[i]);
  }
  MergeCommand merge;
  merge.request.command_line = build.request.command_line;
  EvalCommand eval;
  SynthCommand synth;
  ViewCommand view;
  InfoCommand info;
  build.Add(app);
  merge.Add(app);
  eval.Add(app);
  synth.Add(app);
  view.Add(app);
  info.Add(app);

  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    // One sentence of ours, like every other refusal, naming the option CLI11 found wrong.
    if (*build.command) build.RecoverEarlierSwap();
    std::fprintf(stderr, "stillmap: error: %s (--help lists the options)\n", e.what());
    return 2;
  }

  stillmap::SetLibraryMessages(build.verbose);
  try {
    if (*build.command) build.Run();
    if (*merge.command) merge.Run();
    if (*eval.command) eval.Run();
    if (*synth.command) synth.Run();
    if (*view.command) view.Run();
    if (*info.command) info.Run();
  } catch (const stillmap::InputError& e) {
    std::fprintf(stderr, "stillmap: error: %s\n", e.what());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "stillmap: failed: %s\n", e.what());
    return 1;
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return Run(argc, argv);
  } catch (const std::exception& e) {  // e.g. logging set-up; everything else is handled in Run
    std::fprintf(stderr, "stillmap: failed: %s\n", e.what());
    return 1;
  }
}
