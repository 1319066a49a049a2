// The subcommands that read or make files without building a map (eval, synth, view, info):
// each turns its options into one library call.
#pragma once

#include <CLI/CLI.hpp>
#include <string>

#include "stillmap/pipeline/commands.h"
#include "stillmap/synth/synthetic.h"

namespace stillmap_app {

struct EvalCommand {
  stillmap::EvalRequest request;
  CLI::App* command = nullptr;
  void Add(CLI::App& app);
  void Run() const;
};

struct SynthCommand {
  stillmap::SynthOptions options;
  std::string out_dir;
  bool no_noise = false;
  CLI::App* command = nullptr;
  void Add(CLI::App& app);
  void Run();
};

struct ViewCommand {
  std::string out_dir;
  bool png = false;
  std::string screenshot;
  CLI::App* command = nullptr;
  void Add(CLI::App& app);
  void Run() const;
};

struct InfoCommand {
  std::string sequence_dir;
  std::string camera_preset;
  CLI::App* command = nullptr;
  void Add(CLI::App& app);
  void Run() const;
};

}  // namespace stillmap_app
