// Points sorted into cubic cells, for searches within a cell's edge of a point (map_quality.cpp).
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <utility>
#include <vector>

#include "voxel_key.h"

namespace stillmap {

// The points, in the order of their cells' keys, and each occupied cell's key and first point.
// Every point within `edge` of a point of cell c lies in c or one of its 26 neighbours, so a
// search visits those cells' points only. Leaner than PCL's KdTreeFLANN, which holds the points
// three times (the cloud, its own array, FLANN's reordered copy) besides its index: here they are
// held once, 12 bytes a point, and 12 bytes a cell.
class CellGrid {
 public:
  // `edge_m` at least the largest search distance.
  CellGrid(std::vector<Eigen::Vector3f> points, float edge_m)
      : per_metre_(1.0f / (edge_m * (1.0f + kEdgeMargin))) {
    std::sort(
        points.begin(), points.end(),
        [this](const Eigen::Vector3f& a, const Eigen::Vector3f& b) { return Key(a) < Key(b); });
    points_ = std::move(points);
    for (size_t i = 0; i < points_.size(); ++i) {
      const std::int64_t key = Key(points_[i]);
      if (keys_.empty() || keys_.back() != key) {
        keys_.push_back(key);
        first_.push_back(static_cast<std::uint32_t>(i));
      }
    }
    first_.push_back(static_cast<std::uint32_t>(points_.size()));
  }

  size_t cells() const { return keys_.size(); }
  const Eigen::Vector3f* begin(size_t cell) const { return points_.data() + first_[cell]; }
  const Eigen::Vector3f* end(size_t cell) const { return points_.data() + first_[cell + 1]; }
  const std::vector<Eigen::Vector3f>& points() const { return points_; }

  // The cells of `other` (made with the same edge) around this grid's cell `cell` that hold
  // points: calls visit(begin, end) for each.
  template <typename Visit>
  void ForNeighbours(const CellGrid& other, size_t cell, Visit visit) const {
    const Eigen::Array3i c = Cell(*begin(cell));
    for (int dx = -1; dx <= 1; ++dx) {
      for (int dy = -1; dy <= 1; ++dy) {
        for (int dz = -1; dz <= 1; ++dz) {
          const std::int64_t neighbour = VoxelKey(c.x() + dx, c.y() + dy, c.z() + dz);
          const auto it = std::lower_bound(other.keys_.begin(), other.keys_.end(), neighbour);
          if (it == other.keys_.end() || *it != neighbour) continue;
          const size_t found = static_cast<size_t>(it - other.keys_.begin());
          visit(other.begin(found), other.end(found));
        }
      }
    }
  }

 private:
  // The cells are a little larger than asked, so that a point's cell, rounded in float, never
  // leaves a point within the edge two cells away.
  static constexpr float kEdgeMargin = 1e-3f;

  // Clamped so that any finite point has a cell; VoxelKey wraps cells beyond +-2^20 onto
  // others, whose searches then measure a few more distances, never fewer.
  int Axis(float coordinate) const {
    return static_cast<int>(std::clamp(std::floor(coordinate * per_metre_), -1e9f, 1e9f));
  }
  Eigen::Array3i Cell(const Eigen::Vector3f& p) const {
    return {Axis(p.x()), Axis(p.y()), Axis(p.z())};
  }
  std::int64_t Key(const Eigen::Vector3f& p) const {
    const Eigen::Array3i c = Cell(p);
    return VoxelKey(c.x(), c.y(), c.z());
  }

  float per_metre_;                      // 1 / the cells' edge
  std::vector<Eigen::Vector3f> points_;  // sorted by Key
  std::vector<std::int64_t> keys_;       // each occupied cell's, ascending
  std::vector<std::uint32_t> first_;     // each cell's first point; then points_.size()
};

}  // namespace stillmap
