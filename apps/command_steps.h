// The steps `stillmap build` and `stillmap merge` share: the configuration from --config and
// --set, the terminal's verbosity, and the summary and warnings at the end.
#pragma once

#include <CLI/CLI.hpp>
#include <string>
#include <vector>

#include "stillmap/pipeline/config.h"

namespace stillmap_app {

// CLI11 converts "-5" to an unsigned option by wrapping around and clamps what overflows: this
// validator lets through only whole numbers that fit in 64 bits unsigned.
extern const CLI::Validator kWholeNumber;

struct ConfigArguments {
  std::string file;               // --config
  std::vector<std::string> sets;  // --set key=value, in order

  // Adds --config (described by `file_help`) and --set to `command`.
  void Add(CLI::App* command, const std::string& file_help);
  // Applies `file_default` when --config is not given and it exists, else --config; then each
  // --set.
  void ApplyTo(stillmap::BuildConfig* config, const std::string& file_default = "") const;
};

// Warnings only under --quiet; returns whether a progress line is drawn.
bool StartRun(bool quiet);

// The run's summary lines (info) and its warnings.
void EndRun(const std::vector<std::string>& summary, const std::vector<std::string>& warnings);

// The configuration keys with their defaults and help, for `build --help`.
std::string ConfigKeysHelp();

}  // namespace stillmap_app
