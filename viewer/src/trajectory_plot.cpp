#include "stillmap/viewer/trajectory_plot.h"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "stillmap/io/image_io.h"

namespace stillmap {

double NiceStep(double span, int target) {
  const double raw = span / target;
  const double magnitude = std::pow(10.0, std::floor(std::log10(raw)));
  for (double m : {1.0, 2.0, 5.0}) {
    if (m * magnitude >= raw) return m * magnitude;
  }
  return 10.0 * magnitude;
}

cv::Mat DrawTrajectoryPlot(const AteResult& ate, const TrajectoryPlotOptions& options) {
  const cv::Scalar kWhite(255, 255, 255), kBlack(0, 0, 0), kGrid(225, 225, 225);
  const cv::Scalar kEstimate(200, 90, 20), kError(40, 40, 220);
  cv::Mat image(options.height, options.width, CV_8UC3, kWhite);
  if (ate.groundtruth_positions.empty()) return image;

  // The two axes along which the ground truth extends most form the "top" view.
  Eigen::Vector3d lo = ate.groundtruth_positions.front(), hi = lo;
  for (const auto& points : {ate.groundtruth_positions, ate.aligned_positions}) {
    for (const Eigen::Vector3d& p : points) {
      lo = lo.cwiseMin(p);
      hi = hi.cwiseMax(p);
    }
  }
  std::array<int, 3> axes = {0, 1, 2};
  const Eigen::Vector3d extent = hi - lo;
  std::sort(axes.begin(), axes.end(), [&](int a, int b) { return extent[a] > extent[b]; });
  const int ax = std::min(axes[0], axes[1]);
  const int ay = std::max(axes[0], axes[1]);
  constexpr char kAxisNames[] = "xyz";

  const int left = 90, right = 30, top = 90, bottom = 70;
  const int plot_w = options.width - left - right, plot_h = options.height - top - bottom;
  double span = std::max({extent[ax] / plot_w, extent[ay] / plot_h, 1e-6});  // metres per pixel
  span *= 1.1;
  const double center_x = 0.5 * (lo[ax] + hi[ax]), center_y = 0.5 * (lo[ay] + hi[ay]);
  auto to_pixel = [&](const Eigen::Vector3d& p) {
    return cv::Point2d(left + plot_w / 2.0 + (p[ax] - center_x) / span,
                       top + plot_h / 2.0 - (p[ay] - center_y) / span);
  };
  const int kShift = 4;  // sub-pixel drawing
  // Pixels are clamped far outside the image before the conversion to int, which would wrap.
  auto to_int = [](double value) {
    return std::isfinite(value) ? static_cast<int>(std::lround(std::clamp(value, -1e6, 1e6)))
                                : -1000000;
  };
  auto fixed = [&](cv::Point2d p) {
    return cv::Point(to_int(p.x * (1 << kShift)), to_int(p.y * (1 << kShift)));
  };

  // Grid, ticks and labels in metres. Ticks are counted, not accumulated: far from the origin
  // (1e20 m) x + step == x, and a loop adding the step would never end.
  const double x_min = center_x - span * plot_w / 2.0, x_max = center_x + span * plot_w / 2.0;
  const double y_min = center_y - span * plot_h / 2.0, y_max = center_y + span * plot_h / 2.0;
  const double step = NiceStep(std::max(x_max - x_min, y_max - y_min), 8);
  const double log_step = std::log10(step);
  const int digits =
      std::isfinite(log_step) ? static_cast<int>(std::clamp(-std::floor(log_step), 0.0, 9.0)) : 0;
  auto ticks = [step](double from, double to) {
    std::vector<double> values;
    const double first = std::ceil(from / step), last = std::floor(to / step);
    if (!(std::isfinite(first) && std::isfinite(last)) || last - first > 100) return values;
    for (double n = first; n <= last; n += 1.0) {
      values.push_back(n * step);
      if (values.size() > 100) break;  // n + 1 == n for |n| > 2^53
    }
    return values;
  };
  for (double x : ticks(x_min, x_max)) {
    const int px = to_int(left + plot_w / 2.0 + (x - center_x) / span);
    cv::line(image, {px, top}, {px, top + plot_h}, kGrid, 1);
    cv::putText(image, fmt::format("{:.{}f}", x, digits), {px - 18, top + plot_h + 22},
                cv::FONT_HERSHEY_SIMPLEX, 0.45, kBlack, 1, cv::LINE_AA);
  }
  for (double y : ticks(y_min, y_max)) {
    const int py = to_int(top + plot_h / 2.0 - (y - center_y) / span);
    cv::line(image, {left, py}, {left + plot_w, py}, kGrid, 1);
    cv::putText(image, fmt::format("{:.{}f}", y, digits), {left - 60, py + 5},
                cv::FONT_HERSHEY_SIMPLEX, 0.45, kBlack, 1, cv::LINE_AA);
  }
  cv::rectangle(image, {left, top}, {left + plot_w, top + plot_h}, kBlack, 1);
  cv::putText(image, fmt::format("{} [m]", kAxisNames[ax]),
              {left + plot_w / 2 - 20, options.height - 20}, cv::FONT_HERSHEY_SIMPLEX, 0.6, kBlack,
              1, cv::LINE_AA);
  cv::putText(image, fmt::format("{} [m]", kAxisNames[ay]), {10, top + plot_h / 2},
              cv::FONT_HERSHEY_SIMPLEX, 0.6, kBlack, 1, cv::LINE_AA);

  // Trajectories, then the differences over them, then a marker at the start.
  for (size_t i = 1; i < ate.groundtruth_positions.size(); ++i) {
    cv::line(image, fixed(to_pixel(ate.groundtruth_positions[i - 1])),
             fixed(to_pixel(ate.groundtruth_positions[i])), kBlack, 2, cv::LINE_AA, kShift);
    cv::line(image, fixed(to_pixel(ate.aligned_positions[i - 1])),
             fixed(to_pixel(ate.aligned_positions[i])), kEstimate, 1, cv::LINE_AA, kShift);
  }
  for (size_t i = 0; i < ate.groundtruth_positions.size(); ++i) {
    cv::line(image, fixed(to_pixel(ate.groundtruth_positions[i])),
             fixed(to_pixel(ate.aligned_positions[i])), kError, 1, cv::LINE_AA, kShift);
  }
  cv::circle(image, fixed(to_pixel(ate.groundtruth_positions.front())), 6 << kShift, kBlack, 2,
             cv::LINE_AA, kShift);

  // Legend in a row between the title and the plot, so that it never hides data.
  const std::array<std::pair<cv::Scalar, const char*>, 3> entries = {
      std::make_pair(kBlack, "ground truth (o: start)"),
      std::make_pair(kEstimate, "estimate (aligned)"), std::make_pair(kError, "difference")};
  int x = left;
  for (const auto& [color, label] : entries) {
    cv::line(image, {x, top - 22}, {x + 36, top - 22}, color, 2, cv::LINE_AA);
    cv::putText(image, label, {x + 44, top - 17}, cv::FONT_HERSHEY_SIMPLEX, 0.5, kBlack, 1,
                cv::LINE_AA);
    int baseline = 0;
    x += 44 + cv::getTextSize(label, cv::FONT_HERSHEY_SIMPLEX, 0.5, 1, &baseline).width + 30;
  }
  const std::string title =
      options.title.empty()
          ? fmt::format("ATE RMSE {:.4f} m, max {:.4f} m, {} poses (top view)",
                        ate.translation.rmse, ate.translation.max, ate.translation.count)
          : options.title;
  cv::putText(image, title, {left, 35}, cv::FONT_HERSHEY_SIMPLEX, 0.65, kBlack, 1, cv::LINE_AA);
  return image;
}

void WriteTrajectoryPlot(const std::string& path, const AteResult& ate,
                         const TrajectoryPlotOptions& options) {
  WriteImageAtomically(path, DrawTrajectoryPlot(ate, options));
}

}  // namespace stillmap
