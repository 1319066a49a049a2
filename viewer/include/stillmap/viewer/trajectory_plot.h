// Top-view plot of a trajectory against its ground truth.
#pragma once

#include <opencv2/core.hpp>
#include <string>

#include "stillmap/io/evaluation.h"

namespace stillmap {

struct TrajectoryPlotOptions {
  int width = 1000;   // image width [px]
  int height = 800;   // image height [px]
  std::string title;  // drawn above the plot; empty: "ATE RMSE ..." from the result
};

// A 1-2-5 step giving about `target` intervals over `span` (axis ticks, scale bars).
double NiceStep(double span, int target);

// Draws the associated ground-truth positions (black), the aligned estimate (blue) and the error
// of every pair (red segments) seen from above: the two world axes along which the ground truth
// extends most, equal scale, axes and grid in metres, legend. Deterministic for the same input.
cv::Mat DrawTrajectoryPlot(const AteResult& ate, const TrajectoryPlotOptions& options = {});

// Draws the plot and writes it as PNG (temporary name, then renamed).
void WriteTrajectoryPlot(const std::string& path, const AteResult& ate,
                         const TrajectoryPlotOptions& options = {});

}  // namespace stillmap
