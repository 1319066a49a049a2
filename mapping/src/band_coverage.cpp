#include "stillmap/mapping/band_coverage.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace stillmap {
namespace {

constexpr int kWordBits = 64;
const std::pair<int, int> kNoSpan{1, 0};  // first > last: no layer yet

// Bits [first, last] of a 64-bit word set (0 <= first <= last < 64).
std::uint64_t BitRange(int first, int last) {
  const std::uint64_t upto_last =
      last == kWordBits - 1 ? ~std::uint64_t{0} : (std::uint64_t{1} << (last + 1)) - 1;
  return upto_last & ~((std::uint64_t{1} << first) - 1);
}

}  // namespace

BandCoverage::BandCoverage(const OccupancyGrid& grid, double layer_m, double grazing_deg)
    : width_(grid.width),
      height_(grid.height),
      resolution_(grid.resolution),
      origin_(grid.origin),
      grid_from_world_(grid.world_from_grid.inverse()),
      min_height_(grid.min_height),
      layer_m_(layer_m),
      grazing_slope_(grazing_deg < 90.0 ? std::tan(grazing_deg * M_PI / 180.0)
                                        : std::numeric_limits<double>::infinity()),
      layers_(std::max(
          1, static_cast<int>(std::ceil((grid.max_height - grid.min_height) / layer_m - 1e-9)))),
      words_((layers_ + kWordBits - 1) / kWordBits),
      crossed_(
          static_cast<size_t>(width_) * static_cast<size_t>(height_) * static_cast<size_t>(words_),
          0),
      spanned_(crossed_.size(), 0),
      view_span_(static_cast<size_t>(width_) * static_cast<size_t>(height_), kNoSpan) {}

void BandCoverage::AddView(const KeyframeView& view, const std::vector<Eigen::Vector2f>& pixel_rays,
                           int image_width, double max_range_m, int step) {
  const Eigen::Isometry3d grid_from_camera =
      grid_from_world_ * view.camera_from_world.inverse().cast<double>();
  const Eigen::Vector3d centre = grid_from_camera.translation();
  const int rows = view.depth.rows, cols = view.depth.cols;
  const int image_height = static_cast<int>(pixel_rays.size()) / image_width;
  const auto pixel = [&](int u, int v) -> const Eigen::Vector2f& {
    return pixel_rays[static_cast<size_t>(v) * static_cast<size_t>(image_width) +
                      static_cast<size_t>(u)];
  };
  // Each ray stands for its share of the view, `step` blocks: half of that angle either side
  // [rad], from the rays' spacing down the image's middle column.
  const int middle = image_width / 2;
  const int below = std::min(image_height - 1, image_height / 2 + view.block * step);
  const double half_spread =
      0.5 * std::abs(pixel(middle, below).y() - pixel(middle, image_height / 2).y());
  for (int row = 0; row < rows; row += step) {
    const std::uint16_t* readings = view.depth.ptr<std::uint16_t>(row);
    const int v = std::min(view.block * row + view.block / 2, image_height - 1);
    for (int col = 0; col < cols; col += step) {
      if (readings[col] == 0) continue;  // no reading, or masked
      const int u = std::min(view.block * col + view.block / 2, image_width - 1);
      const Eigen::Vector2f& ray = pixel(u, v);
      const double z = static_cast<double>(readings[col]) * view.depth_unit_m;
      Eigen::Vector3d in_camera(ray.x() * z, ray.y() * z, z);
      const double range = in_camera.norm();
      if (max_range_m > 0.0 && range > max_range_m) in_camera *= max_range_m / range;
      Walk(centre, grid_from_camera * in_camera, half_spread);
    }
  }
  CloseView(centre);
}

void BandCoverage::CloseView(const Eigen::Vector3d& centre) {
  for (const size_t index : touched_) {
    std::pair<int, int>& span = view_span_[index];
    const std::pair<int, int> grazing = GrazingLayers(index, centre);
    const int first = std::max(span.first, grazing.first);
    const int last = std::min(span.second, grazing.second);
    if (first <= last) SetLayers(&spanned_, index, first, last);
    span = kNoSpan;
  }
  touched_.clear();
}

std::pair<int, int> BandCoverage::GrazingLayers(size_t index, const Eigen::Vector3d& centre) const {
  if (std::isinf(grazing_slope_)) return {0, layers_ - 1};
  const size_t row_length = static_cast<size_t>(width_);
  const size_t i = index % row_length, j = index / row_length;
  const Eigen::Vector2d cell_centre =
      origin_ +
      resolution_ * Eigen::Vector2d(static_cast<double>(i) + 0.5, static_cast<double>(j) + 0.5);
  const double reach = grazing_slope_ * (cell_centre - centre.head<2>()).norm();
  return Layers(centre.z() - reach, centre.z() + reach);
}

std::pair<int, int> BandCoverage::Layers(double z0, double z1) const {
  const double lowest = std::floor((z0 - min_height_) / layer_m_);
  const double highest = std::floor((z1 - min_height_) / layer_m_);
  if (highest < 0.0 || lowest > layers_ - 1) return kNoSpan;
  return {static_cast<int>(std::max(0.0, lowest)),
          static_cast<int>(std::min<double>(layers_ - 1, highest))};
}

void BandCoverage::SetLayers(std::vector<std::uint64_t>* bits, size_t index, int first, int last) {
  std::uint64_t* cell = &(*bits)[index * static_cast<size_t>(words_)];
  for (int w = first / kWordBits; w <= last / kWordBits; ++w) {
    const int lo = std::max(first, w * kWordBits) - w * kWordBits;
    const int hi = std::min(last, w * kWordBits + kWordBits - 1) - w * kWordBits;
    cell[w] |= BitRange(lo, hi);
  }
}

void BandCoverage::Walk(const Eigen::Vector3d& a, const Eigen::Vector3d& b, double half_spread) {
  const Eigen::Vector3d d = b - a;
  const double spread_m = d.norm() * half_spread;  // at the ray's end [m]
  // Cell coordinates (continuous) of the ends.
  const double x0 = (a.x() - origin_.x()) / resolution_, y0 = (a.y() - origin_.y()) / resolution_;
  const double x1 = (b.x() - origin_.x()) / resolution_, y1 = (b.y() - origin_.y()) / resolution_;
  int i = static_cast<int>(std::floor(x0)), j = static_cast<int>(std::floor(y0));
  const int i_end = static_cast<int>(std::floor(x1)), j_end = static_cast<int>(std::floor(y1));
  const int step_i = x1 > x0 ? 1 : -1, step_j = y1 > y0 ? 1 : -1;
  const double inf = std::numeric_limits<double>::infinity();
  const double dx = x1 - x0, dy = y1 - y0;
  // The ray's parameter t in [0, 1] at the next cell border along each axis, and per cell.
  const double delta_i = dx != 0.0 ? std::abs(1.0 / dx) : inf;
  const double delta_j = dy != 0.0 ? std::abs(1.0 / dy) : inf;
  double next_i = dx > 0.0 ? (i + 1 - x0) / dx : dx < 0.0 ? (x0 - i) / -dx : inf;
  double next_j = dy > 0.0 ? (j + 1 - y0) / dy : dy < 0.0 ? (y0 - j) / -dy : inf;
  double t = 0.0;
  for (int cells = std::abs(i_end - i) + std::abs(j_end - j); cells >= 0; --cells) {
    const double t_out = cells == 0 ? 1.0 : std::min({next_i, next_j, 1.0});
    const double z0 = a.z() + t * d.z(), z1 = a.z() + t_out * d.z(), margin = t_out * spread_m;
    Mark(i, j, std::min(z0, z1) - margin, std::max(z0, z1) + margin);
    t = t_out;
    if (next_i < next_j) {
      i += step_i;
      next_i += delta_i;
    } else {
      j += step_j;
      next_j += delta_j;
    }
  }
}

void BandCoverage::Mark(int i, int j, double z0, double z1) {
  if (i < 0 || j < 0 || i >= width_ || j >= height_) return;
  if (z0 > z1) std::swap(z0, z1);
  const auto [first, last] = Layers(z0, z1);
  if (first > last) return;
  const size_t index =
      static_cast<size_t>(j) * static_cast<size_t>(width_) + static_cast<size_t>(i);
  SetLayers(&crossed_, index, first, last);
  std::pair<int, int>& span = view_span_[index];
  if (span.first > span.second) {
    touched_.push_back(index);
    span = {first, last};
  } else {
    span = {std::min(span.first, first), std::max(span.second, last)};
  }
}

void BandCoverage::Join(const BandCoverage& other) {
  CV_Assert(other.crossed_.size() == crossed_.size() && other.layers_ == layers_);
  for (size_t k = 0; k < crossed_.size(); ++k) {
    crossed_[k] |= other.crossed_[k];
    spanned_[k] |= other.spanned_[k];
  }
}

double BandCoverage::UnseenLayer(int i, int j) const {
  const size_t first_word =
      (static_cast<size_t>(j) * static_cast<size_t>(width_) + static_cast<size_t>(i)) *
      static_cast<size_t>(words_);
  int longest = 0, run = 0;
  for (int layer = 0; layer < layers_; ++layer) {
    const size_t word = first_word + static_cast<size_t>(layer / kWordBits);
    const int bit = layer % kWordBits;
    const bool unseen = ((spanned_[word] & ~crossed_[word]) >> bit) & 1U;
    run = unseen ? run + 1 : 0;
    longest = std::max(longest, run);
  }
  return longest * layer_m_;
}

size_t UnknownWhereLayersUnseen(const BandCoverage& coverage, double min_layer_m,
                                OccupancyGrid* grid) {
  size_t changed = 0;
  for (int j = 0; j < grid->height; ++j) {
    for (int i = 0; i < grid->width; ++i) {
      std::int8_t& cell = grid->cells[grid->Index({i, j})];
      if (cell != kGridFree || coverage.UnseenLayer(i, j) < min_layer_m - 1e-9) continue;
      cell = kGridUnknown;
      ++changed;
    }
  }
  return changed;
}

}  // namespace stillmap
