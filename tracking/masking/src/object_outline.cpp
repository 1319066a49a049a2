#include "object_outline.h"

#include <algorithm>
#include <cstdint>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "mask_growth.h"

namespace stillmap {
namespace object_outline {

using mask_growth::Clip;
using mask_growth::Continuous;
using mask_growth::Grow;

cv::Rect Middle(const cv::Rect& box) {
  return {box.x + box.width / 3, box.y + box.height / 4, std::max(1, box.width / 3),
          std::max(1, box.height / 2)};
}

cv::Mat Outline(const cv::Mat& gray, const cv::Mat& depth_m, const cv::Mat& excluded,
                const cv::Mat& confirmed_static, const cv::Rect& box, OutlineMode mode,
                double continuity, bool whole_box) {
  cv::Mat region(box.size(), CV_8UC1, cv::Scalar(0));
  if (mode == OutlineMode::kBox || box.area() == 0) {
    region.setTo(255);
    return region;
  }
  const cv::Rect centre = Middle(cv::Rect(cv::Point(), box.size()));
  const cv::Mat depth = depth_m(box);
  std::vector<int> queue;
  if (mode == OutlineMode::kEdges) {
    cv::Mat edges;
    cv::Canny(gray(box), edges, 50, 150);
    cv::dilate(edges, edges, cv::Mat());  // close one-pixel gaps
    for (int v = centre.y; v < centre.y + centre.height; ++v) {
      for (int u = centre.x; u < centre.x + centre.width; ++u) {
        if (edges.at<std::uint8_t>(v, u) != 0) continue;
        region.at<std::uint8_t>(v, u) = 255;
        queue.push_back(v * box.width + u);
      }
    }
    const std::uint8_t* edge = edges.data;
    Grow(&region, std::move(queue), [edge](int next, int) { return edge[next] == 0; });
    return region;
  }
  // kDepth: the nearer third of the centre's readings is the object (background lies behind it).
  std::vector<float> centre_depths;
  for (int v = centre.y; v < centre.y + centre.height; ++v) {
    for (int u = centre.x; u < centre.x + centre.width; ++u) {
      const float z = depth.at<float>(v, u);
      if (z > 0.0f) centre_depths.push_back(z);
    }
  }
  if (centre_depths.size() < 10) {  // nothing to cut by: keep the box
    region.setTo(255);
    return region;
  }
  const auto nth = centre_depths.begin() + static_cast<long>(centre_depths.size() / 3);
  std::nth_element(centre_depths.begin(), nth, centre_depths.end());
  const float foreground = *nth;
  const float band = 0.1f + 0.05f * foreground;
  // With whole_box, readings in that band anywhere in the box seed too, unless the depth check
  // confirms them static: limbs that background pixels part from the torso (arms, a far leg)
  // are not reached from the centre. Without a verdict map (no reference yet) only the centre.
  const bool whole = whole_box && !confirmed_static.empty();
  const cv::Rect seeded = whole ? cv::Rect(0, 0, box.width, box.height) : centre;
  const cv::Mat confirmed = whole ? cv::Mat(confirmed_static(box)) : cv::Mat();
  for (int v = seeded.y; v < seeded.y + seeded.height; ++v) {
    // Row pointers: stores through a byte pointer would reload the Mats' fields per pixel.
    const float* depth_row = depth.ptr<float>(v);
    const std::uint8_t* confirmed_row = whole ? confirmed.ptr<std::uint8_t>(v) : nullptr;
    std::uint8_t* region_row = region.ptr<std::uint8_t>(v);
    const bool centre_row = v >= centre.y && v < centre.y + centre.height;
    for (int u = seeded.x; u < seeded.x + seeded.width; ++u) {
      const float z = depth_row[u];
      if (whole && confirmed_row[u] != 0 &&
          !(centre_row && u >= centre.x && u < centre.x + centre.width)) {
        continue;
      }
      if (z > 0.0f && std::abs(z - foreground) < band) {
        region_row[u] = 255;
        queue.push_back(v * box.width + u);
      }
    }
  }
  const cv::Mat depth_copy = depth.clone();  // continuous rows for linear indexing
  const float* z = depth_copy.ptr<float>();
  const cv::Mat excluded_copy = excluded.empty() ? cv::Mat(box.size(), CV_8UC1, cv::Scalar(0))
                                                 : cv::Mat(excluded(box).clone());
  const std::uint8_t* out = excluded_copy.data;
  const float farthest = foreground + 1.0f;  // an object is not deeper than this
  Grow(&region, std::move(queue), [z, out, continuity, farthest](int next, int from) {
    return z[next] > 0.0f && z[next] < farthest && out[next] == 0 &&
           Continuous(z[from], z[next], continuity);
  });
  return region;
}

UnclaimedRegions OutlineUnclaimedRegions(const cv::Mat& gray, const cv::Mat& depth_m,
                                         const cv::Mat& geometric, const cv::Mat& claimed,
                                         const cv::Mat& consistent,
                                         const DynamicMaskOptions& options, cv::Mat* mask) {
  UnclaimedRegions regions;
  cv::Mat labels, stats, centroids;
  const int count =
      cv::connectedComponentsWithStats(geometric, labels, stats, centroids, 8, CV_32S);
  std::vector<std::uint8_t> inside(static_cast<size_t>(count), 0);
  for (int v = 0; v < labels.rows; ++v) {
    const int* label = labels.ptr<int>(v);
    const std::uint8_t* claim = claimed.ptr<std::uint8_t>(v);
    for (int u = 0; u < labels.cols; ++u) {
      if (label[u] > 0 && claim[u] != 0) inside[static_cast<size_t>(label[u])] = 1;
    }
  }
  const bool outline = options.unclaimed_outline_min_px > 0 && !consistent.empty();
  for (int k = 1; k < count; ++k) {
    if (inside[static_cast<size_t>(k)] != 0) continue;
    ++regions.count;
    if (!outline || stats.at<int>(k, cv::CC_STAT_AREA) < options.unclaimed_outline_min_px) {
      continue;
    }
    const int width = stats.at<int>(k, cv::CC_STAT_WIDTH);
    const int widen = static_cast<int>(options.unclaimed_outline_widen * width);
    const cv::Rect box =
        Clip(cv::Rect(stats.at<int>(k, cv::CC_STAT_LEFT) - widen, stats.at<int>(k, cv::CC_STAT_TOP),
                      width + 2 * widen, stats.at<int>(k, cv::CC_STAT_HEIGHT)),
             geometric.size());
    const cv::Mat cut = Outline(gray, depth_m, consistent, consistent, box, options.outline,
                                options.continuity, options.outline_whole_box);
    (*mask)(box).setTo(255, cut);
    ++regions.outlined;
  }
  return regions;
}

}  // namespace object_outline
}  // namespace stillmap
