#include "stillmap/tracking/map_recheck.h"

#include <opencv2/imgproc.hpp>

namespace stillmap {

MapRecheck::MapRecheck(const GeometricMasker& geometry, const DynamicMaskOptions& options)
    : geometry_(geometry),
      options_(options),
      max_references_(2 * static_cast<size_t>(options.reference_keyframes)) {}

cv::Mat MapRecheck::Recheck(double time, const cv::Mat& depth_m,
                            const Eigen::Isometry3d& world_from_camera, const cv::Mat& mask,
                            const std::vector<MaskReference*>& later, bool* changed) const {
  *changed = false;
  const double spacing = options_.reference_spacing_s;
  std::vector<const MaskReference*> newest_first;
  for (auto earlier = recent_.rbegin(); earlier != recent_.rend(); ++earlier) {
    newest_first.push_back(&*earlier);
  }
  std::vector<const MaskReference*> references =
      SpreadInTime(newest_first, spacing, max_references_);
  double last = time;
  for (size_t i = 0; i < later.size(); ++i) {
    MaskReference& reference = *later[i];
    const bool newest = i + 1 == later.size();
    if (reference.time - last < spacing && !newest) continue;
    last = reference.time;
    if (references.size() >= max_references_) continue;
    if (reference.nearest_depth_m.empty())
      reference.nearest_depth_m = NearestStaticDepth(reference);
    references.push_back(&reference);
  }
  cv::Mat moving = geometry_.Compute(depth_m, world_from_camera, references);
  if (cv::countNonZero(moving) == 0) return mask;
  const int size = 2 * options_.margin_px + 1;
  cv::dilate(moving, moving, cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(size, size)));
  *changed = true;
  return mask.empty() ? moving : (mask | moving);
}

void MapRecheck::Remember(MaskReference reference, bool mask_changed) {
  MaskReference& done = recent_.emplace_back(std::move(reference));
  if (mask_changed || done.nearest_depth_m.empty()) done.nearest_depth_m = NearestStaticDepth(done);
  while (recent_.size() > 1 &&
         recent_.back().time - recent_.front().time > options_.ReferenceHorizonS()) {
    recent_.pop_front();
  }
}

}  // namespace stillmap
