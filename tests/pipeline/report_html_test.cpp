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

// The page opens with the run at a glance, before any table: command, date, sequence, frames,
// ATE and RPE, speed, map size, the map frame, the warnings and a link to every output.
TEST(ReportHtmlTest, TheSummaryComesFirst) {
  const nlohmann::json report = {{"command", "stillmap build seq -o out"},
                                 {"sequence", "seq"},
                                 {"poses", "tracking"},
                                 {"frames", {{"pairs_used", 620}, {"tracked", 620}, {"fused", 37}}},
                                 {"trajectory_error",
                                  {{"ate_m", {{"rmse", 0.0172}}},
                                   {"rpe_translation_m", {{"rmse", 0.0104}}},
                                   {"rpe_rotation_deg", {{"rmse", 0.74}}},
                                   {"rpe_delta_s", 1.0}}},
                                 {"timing",
                                  {{"started_utc", "2026-11-23T21:00:00Z"},
                                   {"frames_per_second", 21.04},
                                   {"wall_time_s", 29.5},
                                   {"peak_memory_mib", 548.2}}},
                                 {"map", {{"voxels_written", 1212376}, {"voxel_leaf_m", 0.01}}},
                                 {"map_frame", {{"description", "floor: z up & level"}}},
                                 {"warnings", {"the OctoMap is off"}},
                                 {"outputs", {"map.ply", "grid.yaml"}}};
  const std::string html = ReportHtml(report);
  const size_t first_table = html.find("<h2>");
  for (const char* expected :
       {"<code>stillmap build seq -o out</code>", "2026-11-23T21:00:00Z",
        "620 used, 620 posed, 37 "
        "fused",
        "ATE RMSE 17.2 mm, RPE RMSE 10.4 mm and 0.740 deg per 1 s", "21.0 frames/s", "548 MiB",
        "1212376 points", "floor: z up &amp; level", "<li>the OctoMap is off</li>",
        "<a href=\"map.ply\">map.ply</a>", "<a href=\"grid.yaml\">grid.yaml</a>"}) {
    const size_t at = html.find(expected);
    EXPECT_NE(at, std::string::npos) << expected;
    EXPECT_LT(at, first_table) << expected;
  }
  // Without ground truth the trajectory row says so.
  nlohmann::json without = report;
  without["trajectory_error"] = nullptr;
  without["trajectory_error_note"] = "not evaluated: the sequence has no groundtruth.txt";
  EXPECT_NE(ReportHtml(without).find("not evaluated: the sequence has no groundtruth.txt"),
            std::string::npos);
}

}  // namespace
}  // namespace stillmap
