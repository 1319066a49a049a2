// Internal to the masking: pixel verdicts of the depth check and region growth over continuous
// depth, shared by the depth check (geometric_mask.cpp) and the masker (dynamic_mask.cpp).
#pragma once

#include <cmath>
#include <cstdint>
#include <opencv2/core.hpp>
#include <vector>

namespace stillmap {
namespace mask_growth {

// Neighbouring readings a and b [m] are one surface: within 1 cm + `continuity` of a.
inline bool Continuous(float a, float b, double continuity) {
  return std::abs(a - b) <= 0.01f + static_cast<float>(continuity) * a;
}

// Pixel verdicts of the depth check, by strength of evidence (the strongest over references
// wins).
enum : std::uint8_t { kNoVerdict = 0, kConsistent = 1, kCandidate = 2, kSeed = 3 };

inline cv::Rect Clip(const cv::Rect& box, const cv::Size& size) {
  return box & cv::Rect(cv::Point(), size);
}

// Breadth-first growth over 4-neighbours of `region` (CV_8UC1, seeds set) restricted to `allowed`
// pixels (a predicate on the linear index and the pixel grown from).
template <typename Allowed>
void Grow(cv::Mat* region, std::vector<int> queue, const Allowed& allowed) {
  const int width = region->cols, height = region->rows;
  std::uint8_t* out = region->data;
  for (size_t head = 0; head < queue.size(); ++head) {
    const int index = queue[head];
    const int u = index % width, v = index / width;
    const int neighbours[4] = {u > 0 ? index - 1 : -1, u + 1 < width ? index + 1 : -1,
                               v > 0 ? index - width : -1, v + 1 < height ? index + width : -1};
    for (int next : neighbours) {
      if (next < 0 || out[next] != 0 || !allowed(next, index)) continue;
      out[next] = 255;
      queue.push_back(next);
    }
  }
}

}  // namespace mask_growth
}  // namespace stillmap
