// report.html: the figures of report.json in tables, with the renders, as one page a browser
// opens without any tool.
#pragma once

#include <nlohmann/json.hpp>
#include <string>

namespace stillmap {

// Every section of `report` (objects flattened to dotted keys, number lists joined) in a table,
// the best-known sections first, and the images listed under "renders" (paths relative to the
// page). Strings are HTML-escaped.
std::string ReportHtml(const nlohmann::json& report);

}  // namespace stillmap
