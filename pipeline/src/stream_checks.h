// Plausibility of the recorded streams, gathered while the frames are read: a depth scale that is
// far off (a wrong camera.depth_factor) and a colour stream that does not change. Both leave a
// build that runs to the end with a map that is wrong, so they are warnings in the summary.
#pragma once

#include <array>
#include <cstddef>
#include <string>
#include <vector>

#include "stillmap/io/sequence.h"

namespace stillmap {

class StreamChecks {
 public:
  // Depth readings counted in 5 cm bins up to kMaxDepthM (beyond it, in the last).
  static constexpr double kBinM = 0.05;
  static constexpr double kMaxDepthM = 20.0;
  // Where indoor RGB-D recordings read (structured light, time of flight and active stereo
  // alike): half the readings nearer than 8 m, and 5 % of them farther than 1.5 m. Measured
  // figures of the shared sequences are in docs/figures.md.
  static constexpr double kMaxMedianM = 8.0;
  static constexpr double kMin95thPercentileM = 1.5;

  // Counts one frame (frames in order).
  void Add(const Frame& frame);

  // The depth reading below which `share` (0..1) of all readings lie [m]; 0 without readings.
  double DepthQuantile(double share) const;
  // Frames whose colour image equals the previous frame's, byte for byte.
  size_t frozen_colour_frames() const { return frozen_colour_; }
  size_t frames() const { return frames_; }

  // One sentence per implausible stream, naming what to check; `depth_factor` as configured.
  std::vector<std::string> Warnings(double depth_factor) const;

 private:
  std::array<size_t, static_cast<size_t>(kMaxDepthM / kBinM) + 1> depth_bins_{};
  size_t depth_readings_ = 0;
  size_t frames_ = 0;
  size_t frozen_colour_ = 0;
  cv::Mat previous_colour_;
};

}  // namespace stillmap
