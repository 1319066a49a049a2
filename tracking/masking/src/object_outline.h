// Internal to the masking: an object cut out of its box by depth (or edges), for the detections
// and for the moving regions no detection claims (dynamic_mask.cpp).
#pragma once

#include <opencv2/core.hpp>

#include "stillmap/tracking/dynamic_mask.h"

namespace stillmap {
namespace object_outline {

// The middle of a detection's box, which people fill: the middle third across, the middle half
// down.
cv::Rect Middle(const cv::Rect& box);

// The object in `box` cut to its outline. kDepth: the depth-continuous foreground grown from the
// box's centre (people fill the middle of their boxes), not into `excluded` readings; kEdges: the
// region around the centre bounded by Canny edges (paper 000, section II.C); kBox: the whole box.
// Box-sized CV_8UC1.
cv::Mat Outline(const cv::Mat& gray, const cv::Mat& depth_m, const cv::Mat& excluded,
                const cv::Mat& confirmed_static, const cv::Rect& box, OutlineMode mode,
                double continuity, bool whole_box);

// The moving regions of `geometric` that no detection's outline (`claimed`) touches, counted.
// Those of at least options.unclaimed_outline_min_px are outlined into `mask` as a detected
// person is, in their box widened by options.unclaimed_outline_widen of its width on each side:
// a person no detector boxes (close to the lens, cut by the image's edge) whose arms the depth
// check misses while they keep pace with the camera. Only with the depth check's verdicts
// (`consistent` not empty), whose confirmed-static readings are left out.
struct UnclaimedRegions {
  int count = 0;     // moving regions outside every detection
  int outlined = 0;  // of them, outlined into the mask
};
UnclaimedRegions OutlineUnclaimedRegions(const cv::Mat& gray, const cv::Mat& depth_m,
                                         const cv::Mat& geometric, const cv::Mat& claimed,
                                         const cv::Mat& consistent,
                                         const DynamicMaskOptions& options, cv::Mat* mask);

}  // namespace object_outline
}  // namespace stillmap
