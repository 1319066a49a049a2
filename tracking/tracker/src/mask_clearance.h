// Keypoints beside a person the mask holds: where a person's outline crosses the background, or
// an arm the mask missed hangs beside the torso, a corner moves with the person. In a blank
// corridor those corners can outnumber the static ones, and the pose follows the person (the
// synthetic floor's person walking ahead, docs/figures.md). Such a keypoint lies at the person's
// depth within its descriptor's patch of the mask; background behind the outline lies farther and
// keeps its keypoints, and so do keypoints beside small masked regions (a patch of the scene the
// geometric checks flagged).
#pragma once

#include <opencv2/core.hpp>
#include <vector>

#include "stillmap/tracking/features.h"

namespace stillmap {

// Drops from `keypoints` those whose patch (options.mask_clearance_px, times scale_factor per
// pyramid level) holds a pixel of a region of `ignore_mask` (non-zero: moving) of at least
// mask_clearance_min_region_px whose depth is within kClearanceDepth* of the keypoint's, and those
// without depth whose patch holds any pixel of one.
void DropBesideMovingRegions(const cv::Mat& ignore_mask, const cv::Mat& depth_m,
                             const FeatureOptions& options, std::vector<cv::KeyPoint>* keypoints);

}  // namespace stillmap
