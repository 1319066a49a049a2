#include "stillmap/io/image_regions.h"

#include <algorithm>
#include <cstdint>
#include <opencv2/imgproc.hpp>
#include <vector>

namespace stillmap {

bool DropSmallRegions(int min_region_px, cv::Mat* mask) {
  if (min_region_px <= 0) return cv::countNonZero(*mask) > 0;
  CV_Assert(mask->type() == CV_8UC1 && mask->isContinuous());
  cv::Mat labels, stats, centroids;
  const int count = cv::connectedComponentsWithStats(*mask, labels, stats, centroids, 8, CV_32S);
  std::vector<std::uint8_t> keep(static_cast<size_t>(count), 0);
  for (int k = 1; k < count; ++k) {
    keep[static_cast<size_t>(k)] = stats.at<int>(k, cv::CC_STAT_AREA) >= min_region_px;
  }
  if (std::find(keep.begin() + 1, keep.end(), 0) == keep.end()) return count > 1;
  const bool any_kept = std::find(keep.begin() + 1, keep.end(), 1) != keep.end();
  // Locals for the loop: a store through the byte pointer could alias the Mat's fields (perf:
  // reloading them and calling total() per pixel was 2 % of a bonn_crowd_a build).
  const int* label = labels.ptr<int>();
  std::uint8_t* out = mask->data;
  const size_t total = mask->total();
  for (size_t i = 0; i < total; ++i) {
    if (out[i] != 0 && keep[static_cast<size_t>(label[i])] == 0) out[i] = 0;
  }
  return any_kept;
}

}  // namespace stillmap
