#include "stream_checks.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstring>

#include "stillmap/io/option_names.h"

namespace stillmap {

void StreamChecks::Add(const Frame& frame) {
  ++frames_;
  const cv::Mat& colour = frame.color;
  if (!previous_colour_.empty() && previous_colour_.size() == colour.size() &&
      previous_colour_.type() == colour.type() && previous_colour_.isContinuous() &&
      colour.isContinuous() &&
      std::memcmp(previous_colour_.data, colour.data, colour.total() * colour.elemSize()) == 0) {
    ++frozen_colour_;
  }
  previous_colour_ = colour;
  // Every 4th pixel of every 4th row is plenty for quantiles, and cheap.
  for (int r = 0; r < frame.depth_m.rows; r += 4) {
    const float* row = frame.depth_m.ptr<float>(r);
    for (int c = 0; c < frame.depth_m.cols; c += 4) {
      const float z = row[c];
      if (!(z > 0.0f) || !std::isfinite(z)) continue;
      const auto bin = static_cast<size_t>(std::min(static_cast<double>(z), kMaxDepthM) / kBinM);
      ++depth_bins_[std::min(bin, depth_bins_.size() - 1)];
      ++depth_readings_;
    }
  }
}

double StreamChecks::DepthQuantile(double share) const {
  if (depth_readings_ == 0) return 0.0;
  const auto wanted = static_cast<size_t>(share * static_cast<double>(depth_readings_));
  size_t seen = 0;
  for (size_t bin = 0; bin < depth_bins_.size(); ++bin) {
    seen += depth_bins_[bin];
    if (seen > wanted) return (static_cast<double>(bin) + 0.5) * kBinM;
  }
  return kMaxDepthM;
}

std::vector<std::string> StreamChecks::Warnings(double depth_factor) const {
  std::vector<std::string> warnings;
  if (frames_ >= 3 && 2 * frozen_colour_ >= frames_ - 1) {
    warnings.push_back(fmt::format(
        "{} of {} colour frames are identical to the frame before: the colour stream looks "
        "frozen, and tracking follows it (check the recording's colour images)",
        frozen_colour_, frames_));
  }
  const double median = DepthQuantile(0.5), far = DepthQuantile(0.95);
  if (depth_readings_ > 0 && (median > kMaxMedianM || far < kMin95thPercentileM)) {
    warnings.push_back(fmt::format(
        "the depth readings look {} than a room's: half nearer than {:.2f} m, 95 % nearer than "
        "{:.2f} m (indoor RGB-D recordings read a median below {:.0f} m and some readings beyond "
        "{:.1f} m); check the depth scale, {} = {} per metre",
        median > kMaxMedianM ? "farther" : "nearer", median, far, kMaxMedianM, kMin95thPercentileM,
        OptionKey(&CameraOverrides::depth_factor), depth_factor));
  }
  return warnings;
}

}  // namespace stillmap
