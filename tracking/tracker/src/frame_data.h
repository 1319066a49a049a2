// Internal to the tracker: the current frame's features, descriptors and undistorted pixel
// positions bucketed for radius searches, and its feature -> landmark associations.
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <climits>
#include <cstdint>
#include <cstring>
#include <opencv2/core.hpp>
#include <utility>
#include <vector>

#include "hamming.h"
#include "stillmap/io/camera.h"
#include "stillmap/tracking/features.h"

namespace stillmap {

inline Descriptor DescriptorOf(const cv::Mat& descriptors, int row) {
  Descriptor out;
  std::memcpy(out.data(), descriptors.ptr<uint8_t>(row), sizeof(out));
  return out;
}

// The current frame: features, descriptors and undistorted pixel positions, bucketed in a grid
// for radius searches.
class FrameData {
 public:
  FrameData(FrameFeatures features, const Camera& camera)
      : features_(std::move(features)), width_(camera.width), height_(camera.height) {
    const size_t n = features_.size();
    descriptors_.reserve(n);
    pixels_.reserve(n);
    columns_ = (width_ + 2 * kMargin) / kCell + 1;
    rows_ = (height_ + 2 * kMargin) / kCell + 1;
    cells_.assign(static_cast<size_t>(columns_) * static_cast<size_t>(rows_), {});
    for (size_t i = 0; i < n; ++i) {
      descriptors_.push_back(DescriptorOf(features_.descriptors, static_cast<int>(i)));
      const Eigen::Vector2d pixel(camera.fx * features_.normalized[i].x() + camera.cx,
                                  camera.fy * features_.normalized[i].y() + camera.cy);
      pixels_.push_back(pixel);
      cells_[static_cast<size_t>(CellIndex(Column(pixel.x()), Row(pixel.y())))].push_back(
          static_cast<int>(i));
    }
  }

  // Calls f(i) for every feature within `radius` of (u, v).
  template <typename F>
  void ForEachNear(double u, double v, double radius, F&& f) const {
    const int c0 = Column(u - radius), c1 = Column(u + radius);
    const int r0 = Row(v - radius), r1 = Row(v + radius);
    const double r2 = radius * radius;
    for (int r = r0; r <= r1; ++r) {
      for (int c = c0; c <= c1; ++c) {
        for (int i : cells_[static_cast<size_t>(CellIndex(c, r))]) {
          const Eigen::Vector2d& p = pixels_[static_cast<size_t>(i)];
          const double du = p.x() - u, dv = p.y() - v;
          if (du * du + dv * dv <= r2) f(i);
        }
      }
    }
  }

  // The frame's depth and moving-object mask (kept for the keyframe it may become).
  void SetImages(const cv::Mat& depth_m, const cv::Mat& ignore_mask) {
    depth_m_ = depth_m;
    ignore_mask_ = ignore_mask;
  }
  const cv::Mat& depth_m() const { return depth_m_; }
  const cv::Mat& ignore_mask() const { return ignore_mask_; }
  const FrameFeatures& features() const { return features_; }
  FrameFeatures& features() { return features_; }
  const std::vector<Descriptor>& descriptors() const { return descriptors_; }
  std::vector<Descriptor>& descriptors() { return descriptors_; }
  size_t size() const { return features_.size(); }
  int octave(size_t i) const { return features_.keypoints[i].octave; }

 private:
  static constexpr int kCell = 20;    // px
  static constexpr int kMargin = 40;  // undistorted positions may fall slightly outside
  int Column(double u) const {
    return std::clamp(static_cast<int>((u + kMargin) / kCell), 0, columns_ - 1);
  }
  int Row(double v) const {
    return std::clamp(static_cast<int>((v + kMargin) / kCell), 0, rows_ - 1);
  }
  int CellIndex(int column, int row) const { return row * columns_ + column; }

  FrameFeatures features_;
  cv::Mat depth_m_, ignore_mask_;
  std::vector<Descriptor> descriptors_;
  std::vector<Eigen::Vector2d> pixels_;
  int width_, height_;
  int columns_ = 0, rows_ = 0;
  std::vector<std::vector<int>> cells_;
};

// Feature -> landmark associations of the current frame.
struct Association {
  std::vector<int> landmark;  // per feature, -1 none
  std::vector<int> distance;  // Hamming distance of the association
  explicit Association(size_t n) : landmark(n, -1), distance(n, INT_MAX) {}
  int count() const {
    return static_cast<int>(
        std::count_if(landmark.begin(), landmark.end(), [](int id) { return id >= 0; }));
  }
};

}  // namespace stillmap
