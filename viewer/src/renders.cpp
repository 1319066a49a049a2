#include "stillmap/viewer/renders.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>

#include "stillmap/viewer/trajectory_plot.h"

namespace stillmap {
namespace {

// A BGR color usable where OpenCV takes a cv::Scalar (cv::Scalar itself is not a literal type).
struct Bgr {
  double b, g, r;
  operator cv::Scalar() const { return {b, g, r}; }  // NOLINT(google-explicit-constructor)
};
constexpr Bgr kWhite{255, 255, 255}, kBlack{0, 0, 0}, kText{40, 40, 40};
constexpr Bgr kTrajectory{200, 90, 20}, kKeyframe{0, 120, 255}, kFloorGrid{200, 200, 200};
constexpr Bgr kAxisX{0, 0, 220}, kAxisY{0, 160, 0};  // the grid frame's axes
constexpr Bgr kUnknownCell{205, 205, 205}, kBackground{246, 246, 246};
constexpr int kFont = cv::FONT_HERSHEY_SIMPLEX;

void Text(cv::Mat* image, const std::string& text, cv::Point at, double scale = 0.55,
          const cv::Scalar& color = kText) {
  cv::putText(*image, text, at, kFont, scale, color, 1, cv::LINE_AA);
}

// Legend rows (a swatch and a label) from `corner` downwards; `dot` swatches are circles.
struct LegendRow {
  cv::Scalar color;
  std::string label;
  bool dot = false;
};
void Legend(cv::Mat* image, cv::Point corner, const std::vector<LegendRow>& rows) {
  const int row_height = 24;
  cv::rectangle(*image, corner - cv::Point(8, 8),
                corner + cv::Point(262, static_cast<int>(rows.size()) * row_height), kWhite,
                cv::FILLED);
  cv::rectangle(*image, corner - cv::Point(8, 8),
                corner + cv::Point(262, static_cast<int>(rows.size()) * row_height), kText, 1);
  for (size_t k = 0; k < rows.size(); ++k) {
    const cv::Point at = corner + cv::Point(0, static_cast<int>(k) * row_height);
    if (rows[k].dot) {
      cv::circle(*image, at + cv::Point(8, 8), 5, rows[k].color, cv::FILLED, cv::LINE_AA);
    } else {
      cv::rectangle(*image, at, at + cv::Point(16, 14), rows[k].color, cv::FILLED);
      cv::rectangle(*image, at, at + cv::Point(16, 14), kText, 1);
    }
    Text(image, rows[k].label, at + cv::Point(26, 13), 0.5);
  }
}

// The up direction: the grid's floor normal, else the mean of the cameras' up (-y) axes.
Eigen::Vector3d UpOf(const RenderInput& input) {
  if (input.grid) return input.grid->floor.up;
  const Eigen::Vector3d up = MeanCameraUp(input.trajectory);
  return up.norm() > 0.0 ? up.normalized() : Eigen::Vector3d(0, -1, 0);
}

cv::Mat GridTopView(const RenderInput& input, const RenderOptions& options) {
  const OccupancyGrid& grid = *input.grid;
  cv::Mat image(options.height, options.width, CV_8UC3, kBackground);
  const int top = 60, margin = 30;
  const int area_w = options.width - 2 * margin, area_h = options.height - top - margin;
  if (grid.width <= 0 || grid.height <= 0) return image;
  // The drawn extent in cells: the grid, grown to hold the trajectory (the floor right below the
  // camera is seldom in view, so the path often runs outside the grid) and a margin for the scale
  // bar below.
  const Eigen::Isometry3d grid_from_world = grid.world_from_grid.inverse();
  double i_low = 0.0, j_low = 0.0, i_high = grid.width, j_high = grid.height;
  for (const Eigen::Isometry3d& pose : input.trajectory) {
    const Eigen::Vector3d g = grid_from_world * pose.translation();
    const double i = (g.x() - grid.origin.x()) / grid.resolution;
    const double j = (g.y() - grid.origin.y()) / grid.resolution;
    i_low = std::min(i_low, i - 2.0);
    i_high = std::max(i_high, i + 2.0);
    j_low = std::min(j_low, j - 2.0);
    j_high = std::max(j_high, j + 2.0);
  }
  j_low -= 0.08 * (j_high - j_low);  // room for the scale bar
  const double scale =
      std::min(area_w / (i_high - i_low), area_h / (j_high - j_low));  // pixels per cell
  const int draw_w = static_cast<int>(grid.width * scale);
  const int draw_h = static_cast<int>(grid.height * scale);
  const int extent_w = static_cast<int>((i_high - i_low) * scale);
  const int extent_h = static_cast<int>((j_high - j_low) * scale);
  // Pixel of the grid's lower-left corner.
  const cv::Point corner(
      margin + (area_w - extent_w) / 2 + static_cast<int>(-i_low * scale),
      top + (area_h - extent_h) / 2 + extent_h + static_cast<int>(j_low * scale));
  const cv::Point offset(corner.x, corner.y - draw_h);
  cv::Mat cells(grid.height, grid.width, CV_8UC3);
  for (int j = 0; j < grid.height; ++j) {
    for (int i = 0; i < grid.width; ++i) {
      const std::int8_t value = grid.At(i, j);
      cells.at<cv::Vec3b>(grid.height - 1 - j, i) = value == kGridOccupied ? cv::Vec3b(0, 0, 0)
                                                    : value == kGridFree ? cv::Vec3b(255, 255, 255)
                                                                         : cv::Vec3b(205, 205, 205);
    }
  }
  cv::Mat scaled;
  cv::resize(cells, scaled, cv::Size(draw_w, draw_h), 0, 0, cv::INTER_NEAREST);
  scaled.copyTo(image(cv::Rect(offset, scaled.size())));
  auto to_pixel = [&](const Eigen::Vector3d& world) {
    const Eigen::Vector3d g = grid_from_world * world;
    return cv::Point(
        offset.x + static_cast<int>((g.x() - grid.origin.x()) / grid.resolution * scale),
        offset.y + draw_h - static_cast<int>((g.y() - grid.origin.y()) / grid.resolution * scale));
  };
  // Scale bar: a 1-2-5 length near a fifth of the drawn width.
  const double metres_per_pixel = grid.resolution / scale;
  const double bar_m = NiceStep(draw_w * metres_per_pixel / 5.0, 1);
  const int bar_px = static_cast<int>(bar_m / metres_per_pixel);
  // The grid frame's origin and axes (grid.yaml's frame), as long as the scale bar.
  const cv::Point origin = to_pixel(grid.world_from_grid.translation());
  cv::arrowedLine(image, origin, origin + cv::Point(bar_px, 0), kAxisX, 3, cv::LINE_AA, 0, 0.08);
  cv::arrowedLine(image, origin, origin - cv::Point(0, bar_px), kAxisY, 3, cv::LINE_AA, 0, 0.08);
  Text(&image, "x", origin + cv::Point(bar_px + 6, 6));
  Text(&image, "y", origin - cv::Point(4, bar_px + 8));
  // The keyframes under the trajectory, so that the path stays whole.
  for (const Eigen::Isometry3d& pose : input.keyframes) {
    cv::circle(image, to_pixel(pose.translation()), 4, kKeyframe, cv::FILLED, cv::LINE_AA);
  }
  std::vector<cv::Point> path;
  for (const Eigen::Isometry3d& pose : input.trajectory)
    path.push_back(to_pixel(pose.translation()));
  if (path.size() >= 2) cv::polylines(image, path, false, kTrajectory, 2, cv::LINE_AA);
  const cv::Point bar(margin + 10, options.height - margin - 10);
  cv::rectangle(image, bar - cv::Point(6, 26), bar + cv::Point(bar_px + 70, 8), kWhite, cv::FILLED);
  cv::line(image, bar, bar + cv::Point(bar_px, 0), kBlack, 3);
  cv::line(image, bar - cv::Point(0, 6), bar + cv::Point(0, 6), kBlack, 2);
  cv::line(image, bar + cv::Point(bar_px, -6), bar + cv::Point(bar_px, 6), kBlack, 2);
  Text(&image, fmt::format("{:g} m", bar_m), bar + cv::Point(bar_px + 8, 5));
  Text(&image,
       fmt::format("{}2-D occupancy grid, {:.0f} cm cells, band {:.2f}-{:.2f} m above the floor",
                   input.title.empty() ? "" : input.title + ": ", grid.resolution * 100.0,
                   grid.min_height, grid.max_height),
       cv::Point(margin, 35), 0.6);
  Legend(&image, cv::Point(options.width - margin - 257, top + 10),
         {{kBlack, "occupied"},
          {kWhite, "free"},
          {kUnknownCell, "unknown"},
          {kTrajectory, "camera trajectory"},
          {kKeyframe, "keyframes fused", true},
          {kAxisX, "grid frame x (origin)"},
          {kAxisY, "grid frame y"}});
  return image;
}

// The virtual camera of a cloud view, with the cloud's robust extent in floor axes.
struct ViewCamera {
  Eigen::Vector3d ex, ey, up;  // floor axes and up
  Eigen::Vector3d low, high;   // the cloud's 1st and 99th percentiles along them
  Eigen::Matrix3d rotation;    // camera_from_world rows
  Eigen::Vector3d eye;
  double focal = 0.0, cx = 0.0, cy = 0.0;

  cv::Point2d Project(const Eigen::Vector3d& world, double* depth) const {
    const Eigen::Vector3d c = rotation * (world - eye);
    *depth = c.z();
    return cv::Point2d(focal * c.x() / c.z() + cx, focal * c.y() / c.z() + cy);
  }
};

// A camera `elevation_deg` above the floor at `azimuth_deg` around the up axis (0: along the
// floor's x axis), framing the cloud's central 98 %.
ViewCamera FrameCloud(const RenderInput& input, const RenderOptions& options, double azimuth_deg,
                      double elevation_deg) {
  ViewCamera view;
  view.up = UpOf(input);
  const Eigen::Matrix3d axes = FloorAxes(view.up);
  view.ex = axes.row(0).transpose();
  view.ey = axes.row(1).transpose();
  const Eigen::Vector3d &ex = view.ex, &ey = view.ey, &up = view.up;
  // Robust extent: per axis the 1st and 99th percentiles.
  std::vector<double> xs, ys, zs;
  const size_t stride = std::max<size_t>(1, input.cloud.size() / 200000);
  for (size_t i = 0; i < input.cloud.size(); i += stride) {
    const Eigen::Vector3d p = input.cloud[i].position.cast<double>();
    xs.push_back(ex.dot(p));
    ys.push_back(ey.dot(p));
    zs.push_back(up.dot(p));
  }
  // In place: nth_element only reorders, so later calls on the same values stay right.
  auto percentile = [](std::vector<double>& v, double q) {
    const auto nth = v.begin() + static_cast<long>(q * static_cast<double>(v.size() - 1));
    std::nth_element(v.begin(), nth, v.end());
    return *nth;
  };
  view.low = Eigen::Vector3d(percentile(xs, 0.01), percentile(ys, 0.01), percentile(zs, 0.01));
  view.high = Eigen::Vector3d(percentile(xs, 0.99), percentile(ys, 0.99), percentile(zs, 0.99));
  const Eigen::Vector3d centre_f = 0.5 * (view.low + view.high);
  const double radius = 0.5 * (view.high - view.low).norm() + 0.1;
  const Eigen::Vector3d centre = centre_f.x() * ex + centre_f.y() * ey + centre_f.z() * up;
  const double azimuth = azimuth_deg * M_PI / 180.0, elevation = elevation_deg * M_PI / 180.0;
  const Eigen::Vector3d back =
      std::cos(elevation) * (std::cos(azimuth) * ex + std::sin(azimuth) * ey) +
      std::sin(elevation) * up;
  const double half_fov = 25.0 * M_PI / 180.0;  // vertical
  view.focal = 0.5 * options.height / std::tan(half_fov);
  view.eye = centre + back * (radius / std::sin(half_fov));
  const Eigen::Vector3d forward = (centre - view.eye).normalized();
  const Eigen::Vector3d down = -(up - up.dot(forward) * forward).normalized();
  const Eigen::Vector3d right = down.cross(forward);
  view.rotation.row(0) = right.transpose();
  view.rotation.row(1) = down.transpose();
  view.rotation.row(2) = forward.transpose();
  view.cx = 0.5 * options.width;
  view.cy = 0.5 * options.height;
  return view;
}

// The floor's 1 m grid under the cloud.
void DrawFloorGrid(const ViewCamera& view, double floor_height, cv::Mat* image) {
  const Eigen::Vector3d &ex = view.ex, &ey = view.ey, &up = view.up;
  for (int axis = 0; axis < 2; ++axis) {
    const double a0 = std::floor(axis == 0 ? view.low.x() : view.low.y());
    const double a1 = std::ceil(axis == 0 ? view.high.x() : view.high.y());
    const double b0 = std::floor(axis == 0 ? view.low.y() : view.low.x());
    const double b1 = std::ceil(axis == 0 ? view.high.y() : view.high.x());
    for (double a = a0; a <= a1 + 1e-9; a += 1.0) {
      const Eigen::Vector3d p0 =
          (axis == 0 ? a * ex + b0 * ey : b0 * ex + a * ey) + floor_height * up;
      const Eigen::Vector3d p1 =
          (axis == 0 ? a * ex + b1 * ey : b1 * ex + a * ey) + floor_height * up;
      double d0 = 0.0, d1 = 0.0;
      const cv::Point2d q0 = view.Project(p0, &d0), q1 = view.Project(p1, &d1);
      if (d0 > 0.1 && d1 > 0.1) cv::line(*image, q0, q1, kFloorGrid, 1, cv::LINE_AA);
    }
  }
}

// Points, z-buffered, as squares that shrink with distance (about a 1.5 cm footprint).
void DrawPoints(const ViewCamera& view, const std::vector<VoxelPoint>& cloud, cv::Mat* image) {
  cv::Mat depth_buffer(image->rows, image->cols, CV_32FC1, cv::Scalar(0));
  for (const VoxelPoint& point : cloud) {
    double depth = 0.0;
    const cv::Point2d q = view.Project(point.position.cast<double>(), &depth);
    if (depth < 0.1) continue;
    const int size = std::clamp(static_cast<int>(std::ceil(view.focal * 0.015 / depth)), 1, 8);
    const int u0 = static_cast<int>(q.x) - size / 2, v0 = static_cast<int>(q.y) - size / 2;
    for (int v = std::max(0, v0); v < std::min(image->rows, v0 + size); ++v) {
      float* z = depth_buffer.ptr<float>(v);
      cv::Vec3b* pixel = image->ptr<cv::Vec3b>(v);
      for (int u = std::max(0, u0); u < std::min(image->cols, u0 + size); ++u) {
        if (z[u] != 0.0f && z[u] <= depth) continue;
        z[u] = static_cast<float>(depth);
        pixel[u] = cv::Vec3b(point.rgb[2], point.rgb[1], point.rgb[0]);  // RGB -> BGR
      }
    }
  }
}

// The keyframes with their viewing directions (0.25 m long), and the trajectory over them.
void DrawCameras(const ViewCamera& view, const RenderInput& input, cv::Mat* image) {
  for (const Eigen::Isometry3d& pose : input.keyframes) {
    double depth = 0.0;
    const cv::Point2d q = view.Project(pose.translation(), &depth);
    if (depth <= 0.1) continue;
    cv::circle(*image, q, 5, kKeyframe, cv::FILLED, cv::LINE_AA);
    double d2 = 0.0;
    const cv::Point2d tip = view.Project(pose * Eigen::Vector3d(0, 0, 0.25), &d2);
    if (d2 > 0.1) cv::line(*image, q, tip, kKeyframe, 2, cv::LINE_AA);
  }
  // The trajectory last, over the keyframes.
  std::vector<cv::Point> path;
  for (const Eigen::Isometry3d& pose : input.trajectory) {
    double depth = 0.0;
    const cv::Point2d q = view.Project(pose.translation(), &depth);
    if (depth > 0.1) path.emplace_back(q);
  }
  if (path.size() >= 2) cv::polylines(*image, path, false, kTrajectory, 2, cv::LINE_AA);
}

// A perspective view of the cloud from `azimuth_deg` around the up axis (0: along the floor's
// x axis), `elevation_deg` above the floor, framing the cloud's central 98 %.
cv::Mat CloudView(const RenderInput& input, const RenderOptions& options, double azimuth_deg,
                  double elevation_deg, const std::string& name) {
  cv::Mat image(options.height, options.width, CV_8UC3, kBackground);
  const ViewCamera view = FrameCloud(input, options, azimuth_deg, elevation_deg);
  // The floor grid first (points draw over it), the cameras on top.
  if (input.grid) DrawFloorGrid(view, -input.grid->floor.offset, &image);
  DrawPoints(view, input.cloud, &image);
  DrawCameras(view, input, &image);
  Text(&image,
       fmt::format("{}colored cloud, {} points ({})", input.title.empty() ? "" : input.title + ": ",
                   input.cloud.size(), name),
       cv::Point(30, 35), 0.6);
  std::vector<LegendRow> rows = {{kTrajectory, "camera trajectory"},
                                 {kKeyframe, "keyframes fused (and view)", true}};
  if (input.grid) rows.push_back({kFloorGrid, "floor grid: 1 m squares"});
  Legend(&image, cv::Point(options.width - 290, 60), rows);
  return image;
}

}  // namespace

std::vector<std::pair<std::string, cv::Mat>> RenderViews(const RenderInput& input,
                                                         const RenderOptions& options) {
  std::vector<std::pair<std::string, cv::Mat>> views;
  if (input.grid) views.emplace_back("grid_top.png", GridTopView(input, options));
  if (!input.cloud.empty()) {
    // From behind the start (opposite the first camera's view) and from the side.
    double azimuth = 225.0;
    if (!input.trajectory.empty()) {
      const Eigen::Vector3d view =
          FloorAxes(UpOf(input)) * input.trajectory.front().linear().col(2);
      azimuth = std::atan2(-view.y(), -view.x()) * 180.0 / M_PI;
    }
    // The second view from high up and turned 60 degrees: a room's near walls, which hide its
    // inside from a low side view, do not hide it from there.
    views.emplace_back("cloud_view_1.png", CloudView(input, options, azimuth, 35.0,
                                                     "seen from behind the first camera"));
    views.emplace_back("cloud_view_2.png", CloudView(input, options, azimuth + 60.0, 65.0,
                                                     "seen from above, turned 60 degrees"));
  }
  return views;
}

}  // namespace stillmap
