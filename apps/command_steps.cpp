#include "command_steps.h"

#include <spdlog/spdlog.h>

#include <charconv>
#include <cstdint>
#include <filesystem>

#include "stillmap/pipeline/progress.h"

namespace stillmap_app {

const CLI::Validator kWholeNumber(
    [](std::string& text) -> std::string {
      std::uint64_t value = 0;
      const char* end = text.data() + text.size();
      const auto [stop, error] = std::from_chars(text.data(), end, value);
      if (text.empty() || error != std::errc() || stop != end) {
        return "'" + text + "' is not a whole number from 0 to 18446744073709551615";
      }
      return "";
    },
    "UINT");

void ConfigArguments::Add(CLI::App* command, const std::string& file_help) {
  command->add_option("--config", file, file_help);
  command->add_option("--set", sets, "key=value; overrides --config (repeatable)");
}

void ConfigArguments::ApplyTo(stillmap::BuildConfig* config,
                              const std::string& file_default) const {
  if (!file.empty()) {
    stillmap::ApplyConfigFile(config, file);
  } else if (!file_default.empty() && std::filesystem::exists(file_default)) {
    stillmap::ApplyConfigFile(config, file_default);
  }
  for (const std::string& argument : sets) stillmap::ApplySetArgument(config, argument);
}

bool StartRun(bool quiet) {
  if (quiet) spdlog::set_level(spdlog::level::warn);
  return !quiet && stillmap::StderrIsTerminal();
}

void EndRun(const std::vector<std::string>& summary, const std::vector<std::string>& warnings) {
  for (const std::string& line : summary) spdlog::info("{}", line);
  for (const std::string& warning : warnings) spdlog::warn("{}", warning);
}

std::string ConfigKeysHelp() {
  std::string text =
      "Configuration keys (--set key=value, or in --config FILE.yaml), with their defaults:\n";
  for (const stillmap::ConfigKeyInfo& key : stillmap::ListConfigKeys()) {
    const std::string value = key.default_value.empty() ? "(from the sequence)" : key.default_value;
    text += "  " + key.name + " = " + value + "\n      " + key.help + "\n";
  }
  return text;
}

}  // namespace stillmap_app
