#include "mask_clearance.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <opencv2/imgproc.hpp>

#include "stillmap/io/image_regions.h"

namespace stillmap {
namespace {

// "At the person's depth": within 0.1 m plus 5 % of the keypoint's depth (the masks' own
// depth-continuity step, masking.grow_depth_difference_m, plus the sensor's noise at range).
constexpr float kClearanceDepthM = 0.1f;
constexpr float kClearanceDepthShare = 0.05f;

// Nonzero where `ignore_mask` holds a region of at least `min_region_px` pixels; empty when it
// holds none.
cv::Mat LargeRegions(const cv::Mat& ignore_mask, int min_region_px) {
  if (cv::countNonZero(ignore_mask) < std::max(min_region_px, 1)) return {};
  cv::Mat regions = ignore_mask != 0;
  if (!DropSmallRegions(min_region_px, &regions)) return {};
  return regions;
}

// Whether a pixel of `regions` in `box` lies at `depth` (a keypoint without depth: any pixel).
bool RegionAtDepth(const cv::Mat& regions, const cv::Mat& depth_m, const cv::Rect& box,
                   float depth) {
  const float tolerance = kClearanceDepthM + kClearanceDepthShare * depth;
  for (int y = box.y; y < box.y + box.height; ++y) {
    const std::uint8_t* region = regions.ptr<std::uint8_t>(y);
    const float* z = depth_m.empty() ? nullptr : depth_m.ptr<float>(y);
    for (int x = box.x; x < box.x + box.width; ++x) {
      if (region[x] == 0) continue;
      if (!(depth > 0.0f) || z == nullptr || (z[x] > 0.0f && std::abs(z[x] - depth) <= tolerance))
        return true;
    }
  }
  return false;
}

}  // namespace

void DropBesideMovingRegions(const cv::Mat& ignore_mask, const cv::Mat& depth_m,
                             const FeatureOptions& options, std::vector<cv::KeyPoint>* keypoints) {
  if (!(options.mask_clearance_px > 0.0) || keypoints->empty() || ignore_mask.empty()) return;
  const cv::Mat regions = LargeRegions(ignore_mask, options.mask_clearance_min_region_px);
  if (regions.empty()) return;
  cv::Mat region_sum;  // summed-area table: a patch without any region pixel in four reads
  cv::integral(regions, region_sum, CV_32S);
  const cv::Rect image(0, 0, regions.cols, regions.rows);
  const auto beside = [&](const cv::KeyPoint& keypoint) {
    const double r = options.mask_clearance_px *
                     std::pow(static_cast<double>(options.scale_factor), keypoint.octave);
    const int x0 = static_cast<int>(std::floor(keypoint.pt.x - r));
    const int y0 = static_cast<int>(std::floor(keypoint.pt.y - r));
    const int x1 = static_cast<int>(std::floor(keypoint.pt.x + r)) + 1;
    const int y1 = static_cast<int>(std::floor(keypoint.pt.y + r)) + 1;
    const cv::Rect box = cv::Rect(x0, y0, x1 - x0, y1 - y0) & image;
    if (box.empty()) return false;
    const int held = region_sum.at<int>(box.y + box.height, box.x + box.width) -
                     region_sum.at<int>(box.y, box.x + box.width) -
                     region_sum.at<int>(box.y + box.height, box.x) +
                     region_sum.at<int>(box.y, box.x);
    if (held == 0) return false;
    const cv::Point pixel(
        std::clamp(static_cast<int>(std::lround(keypoint.pt.x)), 0, regions.cols - 1),
        std::clamp(static_cast<int>(std::lround(keypoint.pt.y)), 0, regions.rows - 1));
    const float depth = depth_m.empty() ? 0.0f : depth_m.at<float>(pixel);
    return RegionAtDepth(regions, depth_m, box, depth);
  };
  keypoints->erase(std::remove_if(keypoints->begin(), keypoints->end(), beside), keypoints->end());
}

}  // namespace stillmap
