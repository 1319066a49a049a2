// A depth image summed up over square cells: what a view read where. The rules that compare two
// keyframes' views use it (the tracker's keyframe culling, the fusion's revisit cells).
#pragma once

#include <opencv2/core.hpp>

namespace stillmap {

// CV_32FC4, one element per cell of cell_px x cell_px pixels (the last row and column of cells
// may reach past the image): the nearest, farthest and mean depth [m] of the cell's readings
// within min_depth..max_depth that `mask` (CV_8UC1, non-zero = left out; or empty) leaves in,
// and their count over cell_px * cell_px. Zeros where no reading counts.
cv::Mat DepthCells(const cv::Mat& depth_m, const cv::Mat& mask, int cell_px, double min_depth,
                   double max_depth);

}  // namespace stillmap
