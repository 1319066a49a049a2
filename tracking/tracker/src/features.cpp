#include "stillmap/tracking/features.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <opencv2/calib3d.hpp>
#include <opencv2/features2d.hpp>

#include "mask_clearance.h"
#include "stillmap/io/error.h"
#include "stillmap/io/option_names.h"

namespace stillmap {

void FeatureOptions::Validate() const {
  if (max_features < 50 || max_features > 100000) {
    throw InputError(
        fmt::format("{} must be between 50 and 100000", OptionKey(*this, max_features)));
  }
  if (grid_columns < 1 || grid_columns > 64 || grid_rows < 1 || grid_rows > 64) {
    throw InputError(fmt::format("{} and {} must be 1..64", OptionKey(*this, grid_columns),
                                 OptionKey(*this, grid_rows)));
  }
  if (pyramid_levels < 1 || pyramid_levels > 16 || !(scale_factor > 1.0f && scale_factor <= 4.0f)) {
    throw InputError(fmt::format("{} must be 1..16 and {} in (1, 4]",
                                 OptionKey(*this, pyramid_levels), OptionKey(*this, scale_factor)));
  }
  if (fast_threshold < 1 || fast_threshold > 255) {
    throw InputError(fmt::format("{} must be 1..255 (a gray-level difference)",
                                 OptionKey(*this, fast_threshold)));
  }
  if (!(max_depth_spread > 0.0))
    throw InputError(fmt::format("{} must be positive", OptionKey(*this, max_depth_spread)));
  if (!(mask_clearance_px >= 0.0 && mask_clearance_px <= 200.0) ||
      mask_clearance_min_region_px < 0) {
    throw InputError(fmt::format("{} must be 0..200 [px] and {} at least 0",
                                 OptionKey(*this, mask_clearance_px),
                                 OptionKey(*this, mask_clearance_min_region_px)));
  }
}

namespace {

// Depth at a sub-pixel position (depth is registered to the color image, so it is read at the
// detected, distorted pixel), bilinear over the four neighbours. Corners often sit on a depth
// edge, where a reading may belong to either surface (and registration errors of real sensors
// are largest): when the 3x3 neighbourhood is not one smooth surface (a missing reading, or a
// spread beyond `max_spread` of the depth), the keypoint gets no depth and is used as a 2-D
// observation only.
float DepthAt(const cv::Mat& depth_m, const cv::Point2f& pixel, float max_spread) {
  const int u0 = static_cast<int>(std::floor(pixel.x)), v0 = static_cast<int>(std::floor(pixel.y));
  if (u0 < 1 || v0 < 1 || u0 + 2 >= depth_m.cols || v0 + 2 >= depth_m.rows) return 0.0f;
  float lo = depth_m.at<float>(v0, u0), hi = lo;
  for (int v = v0 - 1; v <= v0 + 2; ++v) {
    const float* row = depth_m.ptr<float>(v);
    for (int u = u0 - 1; u <= u0 + 2; ++u) {
      lo = std::min(lo, row[u]);
      hi = std::max(hi, row[u]);
    }
  }
  if (!(lo > 0.0f) || hi - lo > max_spread * lo) return 0.0f;
  const float d00 = depth_m.at<float>(v0, u0), d01 = depth_m.at<float>(v0, u0 + 1);
  const float d10 = depth_m.at<float>(v0 + 1, u0), d11 = depth_m.at<float>(v0 + 1, u0 + 1);
  const float fx = pixel.x - static_cast<float>(u0), fy = pixel.y - static_cast<float>(v0);
  return (1 - fy) * ((1 - fx) * d00 + fx * d01) + fy * ((1 - fx) * d10 + fx * d11);
}

// The scale of each pyramid level's image, and its size, as OpenCV's ORB makes them (in float).
struct LevelGeometry {
  float scale, x_ratio, y_ratio;  // scale_factor^octave; full size / level size per axis
};
std::vector<LevelGeometry> Levels(const cv::Size& size, double scale_factor, int levels) {
  std::vector<LevelGeometry> out;
  const float width = static_cast<float>(size.width), height = static_cast<float>(size.height);
  for (int octave = 0; octave < levels; ++octave) {
    const float scale = static_cast<float>(std::pow(scale_factor, octave));
    out.push_back({scale, width / static_cast<float>(cvRound(width / scale)),
                   height / static_cast<float>(cvRound(height / scale))});
  }
  return out;
}

// OpenCV's ORB reports a keypoint found at pyramid level k as its level coordinates times
// scale_factor^k. The level's image is the full image resized to round(size / scale_factor^k)
// pixels with pixel centres aligned, so the full-resolution position is
// (level + 0.5) * size / level_size - 0.5. On 640x480 at 1.2 the reported positions are up to
// 2 px above and left of that, by an amount that changes with the level and the position
// (FeaturePositionsTest).
// Left alone, a landmark seen at a finer level when far and a coarser one when near spreads out
// less than it should as the camera comes closer: on a corridor the camera's forward motion was
// under-estimated by 0.3 % (docs/figures.md, forty-third session).
//
// `to_full`: from ORB's reported positions to full-resolution ones; otherwise back (ORB's
// compute() finds a keypoint's patch in its level from the reported position).
void ConvertPositions(const std::vector<LevelGeometry>& levels, bool to_full,
                      std::vector<cv::KeyPoint>* keypoints) {
  for (cv::KeyPoint& keypoint : *keypoints) {
    if (keypoint.octave <= 0) continue;
    const LevelGeometry& level = levels.at(static_cast<size_t>(keypoint.octave));
    cv::Point2f& pt = keypoint.pt;
    if (to_full) {
      pt.x = (pt.x / level.scale + 0.5f) * level.x_ratio - 0.5f;
      pt.y = (pt.y / level.scale + 0.5f) * level.y_ratio - 0.5f;
    } else {
      pt.x = ((pt.x + 0.5f) / level.x_ratio - 0.5f) * level.scale;
      pt.y = ((pt.y + 0.5f) / level.y_ratio - 0.5f) * level.scale;
    }
  }
}

}  // namespace

FrameFeatures ExtractFeatures(const cv::Mat& gray, const cv::Mat& depth_m, const Camera& camera,
                              const cv::Mat& ignore_mask, const FeatureOptions& options) {
  CV_Assert(gray.type() == CV_8UC1);
  CV_Assert(depth_m.empty() || (depth_m.type() == CV_32FC1 && depth_m.size() == gray.size()));
  // Over-detect, then keep the strongest per cell.
  cv::Ptr<cv::ORB> orb =
      cv::ORB::create(options.max_features * 3, options.scale_factor, options.pyramid_levels, 31, 0,
                      2, cv::ORB::HARRIS_SCORE, 31, options.fast_threshold);
  cv::Mat detect_mask;
  if (!ignore_mask.empty()) detect_mask = ignore_mask == 0;
  std::vector<cv::KeyPoint> candidates;
  orb->detect(gray, candidates, detect_mask);
  const bool exact = options.exact_level_positions;
  std::vector<LevelGeometry> levels;
  if (exact) {
    levels = Levels(gray.size(), options.scale_factor, options.pyramid_levels);
    ConvertPositions(levels, true, &candidates);
  }
  DropBesideMovingRegions(ignore_mask, depth_m, options, &candidates);

  const int cells = options.grid_columns * options.grid_rows;
  const size_t per_cell = static_cast<size_t>((options.max_features + cells - 1) / cells);
  std::vector<std::vector<cv::KeyPoint>> grid(static_cast<size_t>(cells));
  for (const cv::KeyPoint& keypoint : candidates) {
    const int column = std::min(options.grid_columns - 1,
                                static_cast<int>(keypoint.pt.x * options.grid_columns / gray.cols));
    const int row = std::min(options.grid_rows - 1,
                             static_cast<int>(keypoint.pt.y * options.grid_rows / gray.rows));
    const size_t cell = static_cast<size_t>(row) * static_cast<size_t>(options.grid_columns) +
                        static_cast<size_t>(column);
    grid[cell].push_back(keypoint);
  }
  // Each cell keeps its strongest corners up to an equal share; the share that weakly textured
  // cells leave unused goes to the strongest remaining corners anywhere (ORB-SLAM2's quadtree
  // reaches its feature count the same way).
  auto stronger = [](const cv::KeyPoint& a, const cv::KeyPoint& b) {
    return a.response > b.response;
  };
  std::vector<cv::KeyPoint> kept, spare;
  for (std::vector<cv::KeyPoint>& cell : grid) {
    std::sort(cell.begin(), cell.end(), stronger);
    const size_t take = std::min(cell.size(), per_cell);
    kept.insert(kept.end(), cell.begin(), cell.begin() + static_cast<long>(take));
    spare.insert(spare.end(), cell.begin() + static_cast<long>(take), cell.end());
  }
  const size_t wanted = static_cast<size_t>(options.max_features);
  if (kept.size() < wanted && !spare.empty()) {
    const size_t extra = std::min(wanted - kept.size(), spare.size());
    std::partial_sort(spare.begin(), spare.begin() + static_cast<long>(extra), spare.end(),
                      stronger);
    kept.insert(kept.end(), spare.begin(), spare.begin() + static_cast<long>(extra));
  }

  FrameFeatures features;
  if (exact) ConvertPositions(levels, false, &kept);
  orb->compute(gray, kept, features.descriptors);  // may drop keypoints near the border
  if (exact) ConvertPositions(levels, true, &kept);
  features.keypoints = std::move(kept);
  if (features.keypoints.empty()) return features;

  std::vector<cv::Point2f> pixels, rays;
  for (const cv::KeyPoint& keypoint : features.keypoints) pixels.push_back(keypoint.pt);
  const cv::Matx33d k(camera.fx, 0, camera.cx, 0, camera.fy, camera.cy, 0, 0, 1);
  const std::vector<double> distortion = camera.Coefficients();
  cv::undistortPoints(pixels, rays, k, distortion);
  for (size_t i = 0; i < features.keypoints.size(); ++i) {
    features.normalized.emplace_back(rays[i].x, rays[i].y);
    float depth = 0.0f;
    if (!depth_m.empty())
      depth = DepthAt(depth_m, pixels[i], static_cast<float>(options.max_depth_spread));
    features.depth_m.push_back(depth);
  }
  return features;
}

std::vector<SessionFeature> SessionFeatures(const FrameFeatures& features) {
  std::vector<SessionFeature> out(features.size());
  for (size_t i = 0; i < features.size(); ++i) {
    SessionFeature& f = out[i];
    f.u = features.keypoints[i].pt.x;
    f.v = features.keypoints[i].pt.y;
    f.x = static_cast<float>(features.normalized[i].x());
    f.y = static_cast<float>(features.normalized[i].y());
    f.depth_m = features.depth_m[i];
    f.octave = static_cast<std::uint8_t>(std::clamp(features.keypoints[i].octave, 0, 255));
    std::memcpy(f.descriptor.data(), features.descriptors.ptr(static_cast<int>(i)),
                f.descriptor.size());
  }
  return out;
}

}  // namespace stillmap
