// report.html carries every figure of report.json, escaped, and the renders.
#include "stillmap/pipeline/report_html.h"

#include <gtest/gtest.h>

namespace stillmap {
namespace {

TEST(ReportHtmlTest, EveryLeafAppearsEscapedWithTheRenders) {
  const nlohmann::json report = {
      {"sequence", "/data/a<b>"},
      {"frames_per_second", 31.25},
      {"trajectory_error", {{"ate_m", {{"rmse", 0.0123}, {"count", 617}}}}},
      {"grid", {{"origin_m", {-2.5, 0.25}}, {"floor", {{"source", "fitted & checked"}}}}},
      {"map_quality", nullptr},
      {"renders", {"renders/grid_top.png", "renders/cloud_view_1.png"}}};
  const std::string html = ReportHtml(report);
  for (const char* expected :
       {"/data/a&lt;b&gt;", "<th>ate_m.rmse</th><td class=\"v\">0.0123</td>",
        "<th>ate_m.count</th><td class=\"v\">617</td>",
        "<th>origin_m</th><td class=\"v\">-2.5, 0.25",
        "<th>floor.source</th><td class=\"v\">fitted &amp; checked</td>",
        "<th>frames_per_second</th><td class=\"v\">31.25</td>",
        "<th>map_quality</th><td class=\"v\">-</td>", "<img src=\"renders/grid_top.png\"",
        "<img src=\"renders/cloud_view_1.png\""}) {
    EXPECT_NE(html.find(expected), std::string::npos) << expected;
  }
  EXPECT_EQ(html.find("a<b>"), std::string::npos);
  // The trajectory error comes before the grid (the most wanted figures first).
  EXPECT_LT(html.find("<h2>trajectory_error</h2>"), html.find("<h2>grid</h2>"));
}

}  // namespace
}  // namespace stillmap
