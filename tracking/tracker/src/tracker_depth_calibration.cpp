#include "tracker_impl.h"

namespace stillmap {

void Tracker::Impl::CalibrateDepth() {
  const Clock::time_point start = Clock::now();
  std::vector<DepthPair> pairs;
  for (const auto& [id, landmark] : landmarks) {
    const auto& observations = landmark.observations;
    for (size_t k = 1; k < observations.size(); ++k) {
      const auto i = keyframes.find(observations[k - 1].first);
      const auto j = keyframes.find(observations[k].first);
      if (i == keyframes.end() || j == keyframes.end()) continue;
      const auto fi = static_cast<size_t>(observations[k - 1].second);
      const auto fj = static_cast<size_t>(observations[k].second);
      if (fi >= i->second.features.size() || fj >= j->second.features.size()) continue;
      const float zi = i->second.features.depth_m[fi], zj = j->second.features.depth_m[fj];
      if (!UsableDepth(zi) || !UsableDepth(zj)) continue;
      pairs.push_back({i->second.features.normalized[fi], j->second.features.normalized[fj], zi, zj,
                       j->second.camera_from_world * i->second.camera_from_world.inverse()});
    }
  }
  const DepthCorrectionFit fit =
      FitDepthCorrection(pairs, image_outline, options.matching.depth_calibration);
  if (fit.ok) {
    stats.depth_correction = fit.correction;
    ++stats.depth_calibrations;
  } else if (fit.pairs_used >= options.matching.depth_calibration.min_pairs) {
    ++stats.depth_calibrations_refused;
  }
  stats.last_depth_calibration = fit;
  stats.depth_calibration_ms += MillisecondsSince(start);
}

}  // namespace stillmap
