#include "config_values.h"

#include <fmt/format.h>

#include <cmath>
#include <limits>
#include <sstream>
#include <vector>

#include "stillmap/io/error.h"
#include "stillmap/io/file_list.h"

namespace stillmap {
namespace {

[[noreturn]] void BadValue(const ConfigSetting& setting, const std::string& expected) {
  throw InputError(
      fmt::format("{}: {}={}: expected {}", setting.where, setting.key, setting.text, expected));
}

double ToDouble(const ConfigSetting& setting, const std::string& text) {
  double parsed = 0.0;
  if (!ParseFiniteDouble(text, &parsed)) BadValue(setting, "a finite number");
  return parsed;
}

// A whole number that fits `T` exactly (no wrap-around: 4294968496 is refused for an int, not
// read as 1200). Written as digits or in exponent form ("1e3").
template <typename T>
T ToWhole(const ConfigSetting& setting) {
  const double parsed = ToDouble(setting, setting.text);
  // Bounds as doubles that are exactly representable: [lowest, max + 1).
  const double lowest = static_cast<double>(std::numeric_limits<T>::lowest());
  const double beyond = std::ldexp(1.0, std::numeric_limits<T>::digits);
  if (parsed != std::floor(parsed)) BadValue(setting, "a whole number");
  if (parsed < lowest || parsed >= beyond || parsed > 9007199254740992.0) {
    BadValue(setting,
             fmt::format("a whole number in [{}, {}]", std::numeric_limits<T>::lowest(),
                         std::min<double>(static_cast<double>(std::numeric_limits<T>::max()),
                                          9007199254740992.0)));
  }
  return static_cast<T>(parsed);
}

// Shortest text that reads back as the same number.
std::string Number(double value) { return fmt::format("{}", value); }

}  // namespace

void ParseValue(const ConfigSetting& setting, double* value) {
  *value = ToDouble(setting, setting.text);
}

void ParseValue(const ConfigSetting& setting, float* value) {
  const double parsed = ToDouble(setting, setting.text);
  if (std::abs(parsed) > static_cast<double>(std::numeric_limits<float>::max())) {
    BadValue(setting, "a number within the range of a float");
  }
  *value = static_cast<float>(parsed);
}

void ParseValue(const ConfigSetting& setting, int* value) { *value = ToWhole<int>(setting); }

void ParseValue(const ConfigSetting& setting, size_t* value) { *value = ToWhole<size_t>(setting); }

void ParseValue(const ConfigSetting& setting, bool* value) {
  const std::string& text = setting.text;
  if (text == "true" || text == "1" || text == "on" || text == "yes") {
    *value = true;
  } else if (text == "false" || text == "0" || text == "off" || text == "no") {
    *value = false;
  } else {
    BadValue(setting, "true or false");
  }
}

void ParseValue(const ConfigSetting& setting, std::string* value) { *value = setting.text; }

void ParseValue(const ConfigSetting& setting, OutlineMode* value) {
  try {
    *value = ParseOutlineMode(setting.text);
  } catch (const InputError& e) {
    throw InputError(setting.where + ": " + e.what());
  }
}

void ParseValue(const ConfigSetting& setting, PlanarMotionMode* value) {
  if (setting.text == "auto") {
    *value = PlanarMotionMode::kAuto;
    return;
  }
  bool on = false;  // on / off as any switch reads them (true / false, yes / no, 1 / 0)
  try {
    ParseValue(setting, &on);
  } catch (const InputError&) {
    BadValue(setting, "auto, on or off");
  }
  *value = on ? PlanarMotionMode::kOn : PlanarMotionMode::kOff;
}

void ParseValue(const ConfigSetting& setting, std::array<double, 5>* value) {
  std::string text = setting.text;
  for (char& c : text) {
    if (c == '[' || c == ']') c = ' ';
  }
  const std::vector<std::string> fields = SplitFields(text);
  if (fields.size() != value->size()) BadValue(setting, "5 numbers k1,k2,p1,p2,k3");
  for (size_t i = 0; i < fields.size(); ++i) (*value)[i] = ToDouble(setting, fields[i]);
}

void ParseValue(const ConfigSetting& setting, std::array<double, 16>* value) {
  std::string text = setting.text;
  for (char& c : text) {
    if (c == '[' || c == ']') c = ' ';
  }
  const std::vector<std::string> fields = SplitFields(text);
  if (fields.size() != value->size()) BadValue(setting, "16 numbers, a 4x4 matrix row by row");
  for (size_t i = 0; i < fields.size(); ++i) (*value)[i] = ToDouble(setting, fields[i]);
}

void ParseValue(const ConfigSetting& setting, std::optional<Eigen::Vector4d>* value) {
  if (setting.text == "auto") {
    value->reset();
    return;
  }
  std::stringstream in(setting.text);
  Eigen::Vector4d plane;
  for (int i = 0; i < 4; ++i) {
    std::string item;
    if (!(in >> item)) BadValue(setting, "auto or four numbers");
    plane[i] = ToDouble(setting, item);
  }
  std::string extra;
  if (in >> extra) BadValue(setting, "auto or four numbers");
  *value = plane;
}

std::optional<std::string> FormatValue(double value) { return Number(value); }

std::optional<std::string> FormatValue(float value) { return fmt::format("{}", value); }

std::optional<std::string> FormatValue(int value) { return std::to_string(value); }

std::optional<std::string> FormatValue(size_t value) { return std::to_string(value); }

std::optional<std::string> FormatValue(bool value) { return value ? "true" : "false"; }

std::optional<std::string> FormatValue(const std::string& value) {
  std::string quoted = "\"";
  for (const char c : value) {
    if (c == '"' || c == '\\') {
      quoted += '\\';
      quoted += c;
    } else if (static_cast<unsigned char>(c) < 0x20) {
      quoted += fmt::format("\\x{:02x}", static_cast<unsigned>(c));  // YAML's escape
    } else {
      quoted += c;
    }
  }
  return quoted + "\"";
}

std::optional<std::string> FormatValue(OutlineMode value) { return OutlineModeName(value); }

std::optional<std::string> FormatValue(PlanarMotionMode value) {
  return PlanarMotionModeName(value);
}

std::optional<std::string> FormatValue(const std::array<double, 5>& value) {
  return fmt::format("[{}, {}, {}, {}, {}]", value[0], value[1], value[2], value[3], value[4]);
}

std::optional<std::string> FormatValue(const std::array<double, 16>& value) {
  std::string text;
  for (const double v : value) text += (text.empty() ? "" : ", ") + Number(v);
  return "[" + text + "]";
}

std::optional<std::string> FormatValue(const std::optional<Eigen::Vector4d>& value) {
  if (!value) return std::string("auto");
  const Eigen::Vector4d& p = *value;
  return "\"" + Number(p[0]) + " " + Number(p[1]) + " " + Number(p[2]) + " " + Number(p[3]) + "\"";
}

}  // namespace stillmap
