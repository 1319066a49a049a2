#include "stillmap/io/depth_cells.h"

#include <algorithm>
#include <cstdint>
#include <vector>

namespace stillmap {

cv::Mat DepthCells(const cv::Mat& depth_m, const cv::Mat& mask, int cell_px, double min_depth,
                   double max_depth) {
  const int rows = (depth_m.rows + cell_px - 1) / cell_px;
  const int columns = (depth_m.cols + cell_px - 1) / cell_px;
  cv::Mat cells(rows, columns, CV_32FC4, cv::Scalar::all(0.0));
  const auto area = static_cast<float>(cell_px * cell_px);
  std::vector<float> low(static_cast<size_t>(columns)), high(low.size()), sum(low.size());
  std::vector<int> count(low.size());
  for (int row = 0; row < rows; ++row) {
    std::fill(low.begin(), low.end(), 1e9f);
    std::fill(high.begin(), high.end(), 0.0f);
    std::fill(sum.begin(), sum.end(), 0.0f);
    std::fill(count.begin(), count.end(), 0);
    for (int v = row * cell_px; v < std::min(depth_m.rows, (row + 1) * cell_px); ++v) {
      const float* z = depth_m.ptr<float>(v);
      const std::uint8_t* masked = mask.empty() ? nullptr : mask.ptr<std::uint8_t>(v);
      for (int u = 0; u < depth_m.cols; ++u) {
        if (!(z[u] >= min_depth && z[u] <= max_depth) || (masked != nullptr && masked[u] != 0)) {
          continue;
        }
        const auto c = static_cast<size_t>(u / cell_px);
        low[c] = std::min(low[c], z[u]);
        high[c] = std::max(high[c], z[u]);
        sum[c] += z[u];
        ++count[c];
      }
    }
    for (int c = 0; c < columns; ++c) {
      const auto i = static_cast<size_t>(c);
      if (count[i] == 0) continue;
      cells.at<cv::Vec4f>(row, c) = {low[i], high[i], sum[i] / static_cast<float>(count[i]),
                                     static_cast<float>(count[i]) / area};
    }
  }
  return cells;
}

}  // namespace stillmap
