// Connected regions of a mask image: the mask stage drops its specks with it, and the tracker
// finds the moving regions large enough for keypoints to keep clear of.
#pragma once

#include <opencv2/core.hpp>

namespace stillmap {

// Clears every 8-connected region of nonzero pixels of *mask (CV_8UC1, continuous) smaller than
// `min_region_px` pixels; the pixels of the others keep their values. Nothing is cleared when
// `min_region_px` is 0 or less. Returns whether any nonzero pixel is left.
bool DropSmallRegions(int min_region_px, cv::Mat* mask);

}  // namespace stillmap
