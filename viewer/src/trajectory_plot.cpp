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

namespace {

const cv::Scalar kWhite(255, 255, 255);
const cv::Scalar kBlack(0, 0, 0);
const cv::Scalar kGrid(225, 225, 225);
const cv::Scalar kEstimate(200, 90, 20);
const cv::Scalar kError(40, 40, 220);
constexpr int kShift = 4;                                        // sub-pixel drawing
constexpr int kLeft = 90, kRight = 30, kTop = 90, kBottom = 70;  // margins [px]

// Pixels are clamped far outside the image before the conversion to int, which would wrap.
int ToInt(double value) {
  return std::isfinite(value) ? static_cast<int>(std::lround(std::clamp(value, -1e6, 1e6)))
                              : -1000000;
}

cv::Point Fixed(cv::Point2d p) {
  return cv::Point(ToInt(p.x * (1 << kShift)), ToInt(p.y * (1 << kShift)));
}

// The top view: the two axes along which the trajectories extend most, the scale and the centre.
struct PlotFrame {
  int ax = 0, ay = 1;  // world axes drawn as x and y
  int plot_w = 0, plot_h = 0;
  double span = 1.0;  // metres per pixel
  double center_x = 0.0, center_y = 0.0;

  cv::Point2d ToPixel(const Eigen::Vector3d& p) const {
    return cv::Point2d(kLeft + plot_w / 2.0 + (p[ax] - center_x) / span,
                       kTop + plot_h / 2.0 - (p[ay] - center_y) / span);
  }
};

PlotFrame FitPlotFrame(const AteResult& ate, const TrajectoryPlotOptions& options) {
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
  PlotFrame frame;
  frame.ax = std::min(axes[0], axes[1]);
  frame.ay = std::max(axes[0], axes[1]);
  frame.plot_w = options.width - kLeft - kRight;
  frame.plot_h = options.height - kTop - kBottom;
  frame.span = std::max({extent[frame.ax] / frame.plot_w, extent[frame.ay] / frame.plot_h, 1e-6});
  frame.span *= 1.1;
  frame.center_x = 0.5 * (lo[frame.ax] + hi[frame.ax]);
  frame.center_y = 0.5 * (lo[frame.ay] + hi[frame.ay]);
  return frame;
}

// Tick values of `step` within [from, to]. Counted, not accumulated: far from the origin (1e20 m)
// x + step == x, and a loop adding the step would never end.
std::vector<double> Ticks(double from, double to, double step) {
  std::vector<double> values;
  const double first = std::ceil(from / step), last = std::floor(to / step);
  if (!(std::isfinite(first) && std::isfinite(last)) || last - first > 100) return values;
  for (double n = first; n <= last; n += 1.0) {
    values.push_back(n * step);
    if (values.size() > 100) break;  // n + 1 == n for |n| > 2^53
  }
  return values;
}

// Grid, ticks and labels in metres, the frame and the axis names.
void DrawAxes(const PlotFrame& f, const TrajectoryPlotOptions& options, cv::Mat* image) {
  const double x_min = f.center_x - f.span * f.plot_w / 2.0;
  const double x_max = f.center_x + f.span * f.plot_w / 2.0;
  const double y_min = f.center_y - f.span * f.plot_h / 2.0;
  const double y_max = f.center_y + f.span * f.plot_h / 2.0;
  const double step = NiceStep(std::max(x_max - x_min, y_max - y_min), 8);
  const double log_step = std::log10(step);
  const int digits =
      std::isfinite(log_step) ? static_cast<int>(std::clamp(-std::floor(log_step), 0.0, 9.0)) : 0;
  for (double x : Ticks(x_min, x_max, step)) {
    const int px = ToInt(kLeft + f.plot_w / 2.0 + (x - f.center_x) / f.span);
    cv::line(*image, {px, kTop}, {px, kTop + f.plot_h}, kGrid, 1);
    cv::putText(*image, fmt::format("{:.{}f}", x, digits), {px - 18, kTop + f.plot_h + 22},
                cv::FONT_HERSHEY_SIMPLEX, 0.45, kBlack, 1, cv::LINE_AA);
  }
  for (double y : Ticks(y_min, y_max, step)) {
    const int py = ToInt(kTop + f.plot_h / 2.0 - (y - f.center_y) / f.span);
    cv::line(*image, {kLeft, py}, {kLeft + f.plot_w, py}, kGrid, 1);
    cv::putText(*image, fmt::format("{:.{}f}", y, digits), {kLeft - 60, py + 5},
                cv::FONT_HERSHEY_SIMPLEX, 0.45, kBlack, 1, cv::LINE_AA);
  }
  constexpr char kAxisNames[] = "xyz";
  cv::rectangle(*image, {kLeft, kTop}, {kLeft + f.plot_w, kTop + f.plot_h}, kBlack, 1);
  cv::putText(*image, fmt::format("{} [m]", kAxisNames[f.ax]),
              {kLeft + f.plot_w / 2 - 20, options.height - 20}, cv::FONT_HERSHEY_SIMPLEX, 0.6,
              kBlack, 1, cv::LINE_AA);
  cv::putText(*image, fmt::format("{} [m]", kAxisNames[f.ay]), {10, kTop + f.plot_h / 2},
              cv::FONT_HERSHEY_SIMPLEX, 0.6, kBlack, 1, cv::LINE_AA);
}

// Trajectories, then the differences over them, then a marker at the start.
void DrawTrajectories(const AteResult& ate, const PlotFrame& f, cv::Mat* image) {
  const std::vector<Eigen::Vector3d>& truth = ate.groundtruth_positions;
  const std::vector<Eigen::Vector3d>& aligned = ate.aligned_positions;
  for (size_t i = 1; i < truth.size(); ++i) {
    cv::line(*image, Fixed(f.ToPixel(truth[i - 1])), Fixed(f.ToPixel(truth[i])), kBlack, 2,
             cv::LINE_AA, kShift);
    cv::line(*image, Fixed(f.ToPixel(aligned[i - 1])), Fixed(f.ToPixel(aligned[i])), kEstimate, 1,
             cv::LINE_AA, kShift);
  }
  for (size_t i = 0; i < truth.size(); ++i) {
    cv::line(*image, Fixed(f.ToPixel(truth[i])), Fixed(f.ToPixel(aligned[i])), kError, 1,
             cv::LINE_AA, kShift);
  }
  cv::circle(*image, Fixed(f.ToPixel(truth.front())), 6 << kShift, kBlack, 2, cv::LINE_AA, kShift);
}

// Legend in a row between the title and the plot, so that it never hides data; the title.
void DrawLegendAndTitle(const AteResult& ate, const TrajectoryPlotOptions& options,
                        cv::Mat* image) {
  const std::array<std::pair<cv::Scalar, const char*>, 3> entries = {
      std::make_pair(kBlack, "ground truth (o: start)"),
      std::make_pair(kEstimate, "estimate (aligned)"), std::make_pair(kError, "difference")};
  int x = kLeft;
  for (const auto& [color, label] : entries) {
    cv::line(*image, {x, kTop - 22}, {x + 36, kTop - 22}, color, 2, cv::LINE_AA);
    cv::putText(*image, label, {x + 44, kTop - 17}, cv::FONT_HERSHEY_SIMPLEX, 0.5, kBlack, 1,
                cv::LINE_AA);
    int baseline = 0;
    x += 44 + cv::getTextSize(label, cv::FONT_HERSHEY_SIMPLEX, 0.5, 1, &baseline).width + 30;
  }
  const std::string title =
      options.title.empty()
          ? fmt::format("ATE RMSE {:.4f} m, max {:.4f} m, {} poses (top view)",
                        ate.translation.rmse, ate.translation.max, ate.translation.count)
          : options.title;
  cv::putText(*image, title, {kLeft, 35}, cv::FONT_HERSHEY_SIMPLEX, 0.65, kBlack, 1, cv::LINE_AA);
}

}  // namespace

cv::Mat DrawTrajectoryPlot(const AteResult& ate, const TrajectoryPlotOptions& options) {
  cv::Mat image(options.height, options.width, CV_8UC3, kWhite);
  if (ate.groundtruth_positions.empty()) return image;
  const PlotFrame frame = FitPlotFrame(ate, options);
  DrawAxes(frame, options, &image);
  DrawTrajectories(ate, frame, &image);
  DrawLegendAndTitle(ate, options, &image);
  return image;
}

void WriteTrajectoryPlot(const std::string& path, const AteResult& ate,
                         const TrajectoryPlotOptions& options) {
  WriteImageAtomically(path, DrawTrajectoryPlot(ate, options));
}

}  // namespace stillmap
