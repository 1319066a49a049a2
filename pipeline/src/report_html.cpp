#include "stillmap/pipeline/report_html.h"

#include <fmt/format.h>

#include <algorithm>
#include <sstream>
#include <vector>

namespace stillmap {
namespace {

std::string Escape(const std::string& text) {
  std::string out;
  out.reserve(text.size());
  for (char c : text) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

std::string Value(const nlohmann::json& value) {
  if (value.is_null()) return "-";
  if (value.is_string()) return value.get<std::string>();
  if (value.is_boolean()) return value.get<bool>() ? "yes" : "no";
  if (value.is_number_integer() || value.is_number_unsigned()) return value.dump();
  if (value.is_number_float()) return fmt::format("{:.6g}", value.get<double>());
  if (value.is_array()) {
    std::string out;
    for (const nlohmann::json& item : value) {
      if (!out.empty()) out += ", ";
      out += Value(item);
    }
    return out;
  }
  return value.dump();
}

// Rows "a.b.c" -> value for every leaf under `value`.
void Flatten(const std::string& prefix, const nlohmann::json& value,
             std::vector<std::pair<std::string, std::string>>* rows) {
  if (value.is_object() && !value.empty()) {
    for (const auto& [key, item] : value.items()) {
      std::string name = prefix;
      if (!name.empty()) name += ".";
      name += key;
      Flatten(name, item, rows);
    }
    return;
  }
  rows->emplace_back(prefix, Value(value));
}

}  // namespace

std::string ReportHtml(const nlohmann::json& report) {
  std::ostringstream html;
  const std::string sequence = report.value("sequence", std::string());
  html << "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">\n"
       << "<title>stillmap run: " << Escape(sequence) << "</title>\n"
       << "<style>body{font-family:sans-serif;margin:2em;max-width:1300px;color:#222}"
       << "table{border-collapse:collapse;margin:0.5em 0 1.5em}"
       << "td,th{border:1px solid #ccc;padding:3px 10px;text-align:left;font-size:14px}"
       << "td.v{font-family:monospace}h2{margin-top:1.5em;border-bottom:1px solid #ddd}"
       << "img{max-width:100%;border:1px solid #ccc;margin:0.5em 0}</style></head><body>\n"
       << "<h1>stillmap run</h1>\n<p>Sequence <code>" << Escape(sequence) << "</code>, stillmap "
       << Escape(report.value("stillmap_version", std::string())) << ". Every figure of "
       << "<code>report.json</code> is below.</p>\n";
  if (report.contains("renders") && report["renders"].is_array()) {
    html << "<h2>Renders</h2>\n";
    for (const nlohmann::json& image : report["renders"]) {
      const std::string path = Escape(image.get<std::string>());
      html << "<figure><img src=\"" << path << "\" alt=\"" << path << "\"><figcaption>" << path
           << "</figcaption></figure>\n";
    }
  }
  const std::vector<std::string> first = {"frames",  "trajectory_error", "keyframes", "tracking",
                                          "masking", "mask_quality",     "map",       "map_quality",
                                          "grid",    "grid_quality",     "mesh",      "timing_ms"};
  std::vector<std::string> order = first;
  for (const auto& [key, value] : report.items()) {
    if (std::find(order.begin(), order.end(), key) == order.end() && key != "renders") {
      order.push_back(key);
    }
  }
  std::vector<std::pair<std::string, std::string>> scalars;
  for (const std::string& key : order) {
    if (!report.contains(key)) continue;
    const nlohmann::json& value = report[key];
    if (!value.is_object()) {
      scalars.emplace_back(key, Value(value));
      continue;
    }
    std::vector<std::pair<std::string, std::string>> rows;
    Flatten("", value, &rows);
    html << "<h2>" << Escape(key) << "</h2>\n<table>\n";
    for (const auto& [name, text] : rows) {
      html << "<tr><th>" << Escape(name) << "</th><td class=\"v\">" << Escape(text)
           << "</td></tr>\n";
    }
    html << "</table>\n";
  }
  html << "<h2>run</h2>\n<table>\n";
  for (const auto& [name, text] : scalars) {
    html << "<tr><th>" << Escape(name) << "</th><td class=\"v\">" << Escape(text) << "</td></tr>\n";
  }
  html << "</table>\n</body></html>\n";
  return html.str();
}

}  // namespace stillmap
