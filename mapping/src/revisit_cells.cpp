#include "stillmap/mapping/revisit_cells.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "stillmap/io/depth_cells.h"
#include "stillmap/io/error.h"
#include "stillmap/io/option_names.h"

namespace stillmap {

void RevisitOptions::Validate() const {
  if (keyframes_apart < 1)
    throw InputError(fmt::format("{} must be at least 1", OptionKey(*this, keyframes_apart)));
  if (!(view_angle_deg >= 0.0 && view_angle_deg <= 180.0)) {
    throw InputError(fmt::format("{} must lie in 0..180", OptionKey(*this, view_angle_deg)));
  }
  if (!(scale_ratio >= 1.0))
    throw InputError(fmt::format("{} must be at least 1", OptionKey(*this, scale_ratio)));
  if (!(max_seen_share >= 0.0 && max_seen_share <= 1.0)) {
    throw InputError(fmt::format("{} must be in [0, 1]", OptionKey(*this, max_seen_share)));
  }
  if (!(segment_max_seen_share >= 0.0 && segment_max_seen_share <= 1.0)) {
    throw InputError(fmt::format("{} must be in [0, 1]", OptionKey(*this, segment_max_seen_share)));
  }
  if (!(segment_lap_path_m >= 0.0)) {
    throw InputError(fmt::format("{} must be at least 0", OptionKey(*this, segment_lap_path_m)));
  }
}

RevisitCells::RevisitCells(const Camera& camera, const RevisitOptions& options, double min_depth,
                           double max_depth)
    : camera_(camera),
      options_(options),
      min_depth_(min_depth),
      max_depth_(max_depth),
      min_cosine_(std::cos(options.view_angle_deg * M_PI / 180.0)) {
  // Covered asks the two rays to a point, of lengths a and b, to lie within the angle and
  // b / a within [1 / s, s]; the cameras are then |a - b| apart, with |a - b|^2 = a^2 + b^2 -
  // 2 a b cos(angle) <= a^2 + b^2 - 2 a b c, convex in b: largest at b = s a or b = a / s.
  const double s = options.scale_ratio, c = min_cosine_;
  reach_factor_ =
      std::sqrt(std::max({1.0 + s * s - 2.0 * s * c, 1.0 + 1.0 / (s * s) - 2.0 * c / s, 0.0}));
}

CellView RevisitCells::MakeView(int keyframe_id, const cv::Mat& depth_m, const cv::Mat& mask,
                                const Eigen::Isometry3d& world_from_camera, int segment) const {
  CellView view{keyframe_id,
                world_from_camera,
                world_from_camera.inverse(),
                depth_m.size(),
                DepthCells(depth_m, mask, kCell, min_depth_, max_depth_),
                camera_.fx,
                camera_.fy,
                camera_.cx,
                camera_.cy,
                segment};
  // The cells' points lie at their mean depth within the image, whose corners have the longest
  // rays.
  double deepest = 0.0;
  for (int row = 0; row < view.cells.rows; ++row) {
    for (int column = 0; column < view.cells.cols; ++column) {
      deepest = std::max(deepest, static_cast<double>(view.cells.at<cv::Vec4f>(row, column)[2]));
    }
  }
  const double x = std::max(view.cx, view.image_size.width - view.cx) / view.fx;
  const double y = std::max(view.cy, view.image_size.height - view.cy) / view.fy;
  view.reach_m = deepest * std::sqrt(x * x + y * y + 1.0);
  return view;
}

bool RevisitCells::Covered(const Eigen::Vector3d& point_in_world, const Eigen::Vector3d& centre,
                           const CellView& other) const {
  const Eigen::Vector3d p = other.camera_from_world * point_in_world;
  if (!(p.z() > 0.0)) return false;
  const double u = other.fx * p.x() / p.z() + other.cx;
  const double v = other.fy * p.y() / p.z() + other.cy;
  if (!(u >= 0.0 && v >= 0.0 && u < other.cells.cols * kCell && v < other.cells.rows * kCell)) {
    return false;
  }
  // It read a surface at that depth there (5 % and 3 cm of slack, as the tracker's culling), over
  // all of the cell: a cell partly masked (a person passing) did not see the wall behind them.
  const cv::Vec4f& seen =
      other.cells.at<cv::Vec4f>(static_cast<int>(v) / kCell, static_cast<int>(u) / kCell);
  if (seen[3] < kFullCell || p.z() < 0.95 * seen[0] - 0.03 || p.z() > 1.05 * seen[1] + 0.03) {
    return false;
  }
  // From a similar distance and direction: the earlier view sampled the surface as densely.
  const Eigen::Vector3d ray = point_in_world - centre;
  const Eigen::Vector3d other_ray = point_in_world - other.world_from_camera.translation();
  const double range = ray.norm(), other_range = other_ray.norm();
  const double ratio = other_range / range;
  if (ratio > options_.scale_ratio || ratio < 1.0 / options_.scale_ratio) return false;
  return other_ray.dot(ray) >= min_cosine_ * other_range * range;
}

bool RevisitCells::CellSeenBefore(const CellView& view, int row, int column,
                                  const std::vector<const CellView*>& earlier) const {
  const double depth = view.cells.at<cv::Vec4f>(row, column)[2];
  const Eigen::Vector3d centre = view.world_from_camera.translation();
  // Its middle and four points near its corners, at its mean depth, each seen by one of them.
  constexpr double kCorner = 0.5 * kCell - 1.0;
  const double u0 = (column + 0.5) * kCell, v0 = (row + 0.5) * kCell;
  for (const auto& [du, dv] : {std::pair{0.0, 0.0},
                               {-kCorner, -kCorner},
                               {kCorner, -kCorner},
                               {-kCorner, kCorner},
                               {kCorner, kCorner}}) {
    const double u = u0 + du, v = v0 + dv;
    const Eigen::Vector3d point =
        view.world_from_camera *
        (depth * Eigen::Vector3d((u - view.cx) / view.fx, (v - view.cy) / view.fy, 1));
    const auto sees = [&](const CellView* other) { return Covered(point, centre, *other); };
    if (std::none_of(earlier.begin(), earlier.end(), sees)) return false;
  }
  return true;
}

template <typename Take>
std::vector<const CellView*> RevisitCells::Candidates(const CellView& view, Take&& take) const {
  // A centimetre of slack for rounding.
  const double reach = reach_factor_ * view.reach_m + 0.01;
  const Eigen::Vector3d centre = view.world_from_camera.translation();
  std::vector<const CellView*> out;
  for (const CellView& other : remembered_) {
    if (take(other) && (other.world_from_camera.translation() - centre).norm() <= reach) {
      out.push_back(&other);
    }
  }
  return out;
}

cv::Mat RevisitCells::SeenBy(const CellView& view, const std::vector<const CellView*>& earlier,
                             size_t* cells) const {
  *cells = 0;
  if (earlier.empty()) return {};
  cv::Mat seen(view.image_size, CV_8UC1, cv::Scalar(0));
  const cv::Rect image({0, 0}, view.image_size);
  for (int row = 0; row < view.cells.rows; ++row) {
    for (int column = 0; column < view.cells.cols; ++column) {
      const cv::Vec4f& cell = view.cells.at<cv::Vec4f>(row, column);
      if (cell[3] < kReadCell) continue;
      if (!CellSeenBefore(view, row, column, earlier)) continue;
      seen(cv::Rect(column * kCell, row * kCell, kCell, kCell) & image).setTo(255);
      ++*cells;
    }
  }
  if (*cells == 0) return {};
  return seen;
}

cv::Mat RevisitCells::SeenBefore(const CellView& view) {
  if (!options_.enabled) return {};
  const int last_earlier = view.keyframe_id - options_.keyframes_apart;
  const auto earlier = [last_earlier](const CellView& other) {
    return other.keyframe_id <= last_earlier;
  };
  size_t left_out = 0;
  cv::Mat seen = SeenBy(view, Candidates(view, earlier), &left_out);
  cells_left_out_ += left_out;
  return seen;
}

double RevisitCells::SeenShare(const CellView& view, const cv::Mat& seen) {
  if (seen.empty()) return 0.0;
  int read = 0, covered = 0;
  for (int row = 0; row < view.cells.rows; ++row) {
    for (int column = 0; column < view.cells.cols; ++column) {
      if (view.cells.at<cv::Vec4f>(row, column)[3] < kReadCell) continue;
      ++read;
      // SeenBefore marks whole cells: their first pixel says.
      const int u = std::min(column * kCell, seen.cols - 1),
                v = std::min(row * kCell, seen.rows - 1);
      covered += seen.at<std::uint8_t>(v, u) != 0 ? 1 : 0;
    }
  }
  return read > 0 ? static_cast<double>(covered) / read : 0.0;
}

void RevisitCells::Remember(CellView view) { remembered_.push_back(std::move(view)); }

std::optional<cv::Mat> RevisitCells::Admit(CellView view) {
  cv::Mat seen = SeenBefore(view);
  if (options_.max_seen_share < 1.0 && SeenShare(view, seen) > options_.max_seen_share) {
    return std::nullopt;
  }
  Remember(std::move(view));
  return seen;
}

bool RevisitCells::AdmitAcrossSegments(CellView view) {
  if (options_.segment_max_seen_share < 1.0) {
    const double lap_m = options_.segment_lap_path_m;
    const auto other_segment = [&view, lap_m](const CellView& other) {
      return other.segment != view.segment || (lap_m > 0.0 && view.path_m - other.path_m >= lap_m);
    };
    size_t cells = 0;
    const cv::Mat seen = SeenBy(view, Candidates(view, other_segment), &cells);
    if (SeenShare(view, seen) > options_.segment_max_seen_share) return false;
  }
  if (options_.max_seen_share < 1.0 &&
      SeenShare(view, SeenBefore(view)) > options_.max_seen_share) {
    return false;
  }
  Remember(std::move(view));
  return true;
}

void RevisitCells::Repose(const std::map<int, Eigen::Isometry3d>& world_from_keyframe) {
  for (CellView& view : remembered_) {
    const auto it = world_from_keyframe.find(view.keyframe_id);
    if (it == world_from_keyframe.end()) continue;
    view.world_from_camera = it->second;
    view.camera_from_world = it->second.inverse();
  }
}

}  // namespace stillmap
