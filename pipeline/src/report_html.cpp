#include "stillmap/pipeline/report_html.h"

#include <fmt/format.h>

#include <algorithm>
#include <initializer_list>
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

// A figure at `path` (e.g. {"trajectory_error", "ate_m", "rmse"}), or null.
nlohmann::json At(const nlohmann::json& report, std::initializer_list<const char*> path) {
  const nlohmann::json* value = &report;
  for (const char* key : path) {
    if (!value->is_object() || !value->contains(key)) return nullptr;
    value = &(*value)[key];
  }
  return *value;
}

std::string Number(const nlohmann::json& value, double scale, const char* format) {
  if (!value.is_number()) return "";
  return fmt::format(fmt::runtime(format), value.get<double>() * scale);
}

std::string TrajectoryLine(const nlohmann::json& report) {
  const nlohmann::json ate = At(report, {"trajectory_error", "ate_m", "rmse"});
  if (!ate.is_number()) {
    const nlohmann::json note = At(report, {"trajectory_error_note"});
    return note.is_string() ? note.get<std::string>() : "not evaluated";
  }
  std::string line = "ATE RMSE " + Number(ate, 1e3, "{:.1f}") + " mm";
  const nlohmann::json rpe_t = At(report, {"trajectory_error", "rpe_translation_m", "rmse"});
  const nlohmann::json rpe_r = At(report, {"trajectory_error", "rpe_rotation_deg", "rmse"});
  if (rpe_t.is_number() && rpe_r.is_number()) {
    line += ", RPE RMSE " + Number(rpe_t, 1e3, "{:.1f}") + " mm and " +
            Number(rpe_r, 1.0, "{:.3f}") + " deg per " +
            Number(At(report, {"trajectory_error", "rpe_delta_s"}), 1.0, "{:g}") + " s";
  }
  return line;
}

// The run at a glance, above the tables: each row (name, HTML already escaped).
std::vector<std::pair<std::string, std::string>> SummaryRows(const nlohmann::json& report) {
  std::vector<std::pair<std::string, std::string>> rows;
  auto text = [&](const nlohmann::json& value) { return Escape(Value(value)); };
  rows.emplace_back("command", "<code>" + text(At(report, {"command"})) + "</code>");
  rows.emplace_back("started (UTC)", text(At(report, {"timing", "started_utc"})));
  rows.emplace_back("sequence", "<code>" + text(At(report, {"sequence"})) + "</code>, poses " +
                                    text(At(report, {"poses"})));
  rows.emplace_back("frames", text(At(report, {"frames", "pairs_used"})) + " used, " +
                                  text(At(report, {"frames", "tracked"})) + " posed, " +
                                  text(At(report, {"frames", "fused"})) + " fused into the map");
  rows.emplace_back("trajectory", Escape(TrajectoryLine(report)));
  rows.emplace_back(
      "speed",
      Number(At(report, {"timing", "frames_per_second"}), 1.0, "{:.1f}") + " frames/s, " +
          Number(At(report, {"timing", "wall_time_s"}), 1.0, "{:.1f}") + " s, peak memory " +
          Number(At(report, {"timing", "peak_memory_mib"}), 1.0, "{:.0f}") + " MiB; CPU " +
          Number(At(report, {"timing", "cpu", "per_frame_ms"}), 1.0, "{:.1f}") + " ms per frame, " +
          Number(At(report, {"timing", "cpu", "cores_busy_mean"}), 1.0, "{:.2f}") + " of " +
          Number(At(report, {"timing", "cpu", "cores"}), 1.0, "{:.0f}") +
          " cores busy (timing.cpu has it by thread)");
  rows.emplace_back("map", text(At(report, {"map", "voxels_written"})) + " points of " +
                               text(At(report, {"map", "voxel_leaf_m"})) + " m voxels");
  rows.emplace_back("map frame", text(At(report, {"map_frame", "description"})));
  const nlohmann::json warnings = At(report, {"warnings"});
  std::string list;
  if (warnings.is_array()) {
    for (const nlohmann::json& warning : warnings) list += "<li>" + text(warning) + "</li>";
  }
  rows.emplace_back("warnings", list.empty() ? "none" : "<ul>" + list + "</ul>");
  std::string links;
  const nlohmann::json outputs = At(report, {"outputs"});
  if (outputs.is_array()) {
    for (const nlohmann::json& file : outputs) {
      const std::string name = Escape(Value(file));
      if (!links.empty()) links += " &middot; ";
      links.append("<a href=\"").append(name).append("\">").append(name).append("</a>");
    }
  }
  rows.emplace_back("outputs", links);
  return rows;
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
       << Escape(report.value("stillmap_version", std::string())) << ". The run at a glance; "
       << "every figure of <code>report.json</code> is in the tables below.</p>\n"
       << "<table class=\"summary\">\n";
  for (const auto& [name, cell] : SummaryRows(report)) {
    html << "<tr><th>" << Escape(name) << "</th><td>" << cell << "</td></tr>\n";
  }
  html << "</table>\n";
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
                                          "grid",    "grid_quality",     "mesh",      "timing"};
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
