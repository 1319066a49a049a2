// Configuration values as text: parsed from a YAML scalar or `--set key=value`, and written as
// config.yaml holds them (reading the text back gives the same value).
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstddef>
#include <optional>
#include <string>

#include "stillmap/tracking/dynamic_mask.h"
#include "stillmap/tracking/planar_motion.h"

namespace stillmap {

// One value being set: the key, its text and where it was given (a file and line, or "--set"),
// for the error messages.
struct ConfigSetting {
  const std::string& key;
  const std::string& text;
  const std::string& where;
};

// Each throws InputError naming where, the key and the value for a value of the wrong type or
// out of the field type's range (a whole number never wraps around).
void ParseValue(const ConfigSetting& setting, double* value);
void ParseValue(const ConfigSetting& setting, float* value);
void ParseValue(const ConfigSetting& setting, int* value);
void ParseValue(const ConfigSetting& setting, size_t* value);
void ParseValue(const ConfigSetting& setting, bool* value);
void ParseValue(const ConfigSetting& setting, std::string* value);
void ParseValue(const ConfigSetting& setting, OutlineMode* value);
void ParseValue(const ConfigSetting& setting, PlanarMotionMode* value);
void ParseValue(const ConfigSetting& setting, std::array<double, 5>* value);   // "k1,k2,p1,p2,k3"
void ParseValue(const ConfigSetting& setting, std::array<double, 16>* value);  // 4x4, row-major
void ParseValue(const ConfigSetting& setting,
                std::optional<Eigen::Vector4d>* value);  // auto|a b c d

template <typename T>
void ParseValue(const ConfigSetting& setting, std::optional<T>* value) {
  T parsed{};
  ParseValue(setting, &parsed);
  *value = parsed;
}

// The value as config.yaml writes it; std::nullopt for an unset optional value.
std::optional<std::string> FormatValue(double value);
std::optional<std::string> FormatValue(float value);
std::optional<std::string> FormatValue(int value);
std::optional<std::string> FormatValue(size_t value);
std::optional<std::string> FormatValue(bool value);
std::optional<std::string> FormatValue(const std::string& value);  // quoted
std::optional<std::string> FormatValue(OutlineMode value);
std::optional<std::string> FormatValue(PlanarMotionMode value);
std::optional<std::string> FormatValue(const std::array<double, 5>& value);
std::optional<std::string> FormatValue(const std::array<double, 16>& value);
std::optional<std::string> FormatValue(const std::optional<Eigen::Vector4d>& value);

template <typename T>
std::optional<std::string> FormatValue(const std::optional<T>& value) {
  if (!value) return std::nullopt;
  return FormatValue(*value);
}

}  // namespace stillmap
