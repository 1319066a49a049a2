// The map re-check: before a keyframe is fused into the map, paper 002's depth check runs again
// on it against keyframes on both sides of it in time, with final poses where they exist. It
// catches people the online check could not see yet (e.g. in the first keyframe, which has no
// earlier reference).
#pragma once

#include <Eigen/Geometry>
#include <deque>
#include <opencv2/core.hpp>
#include <vector>

#include "stillmap/tracking/dynamic_mask.h"

namespace stillmap {

class MapRecheck {
 public:
  // Uses `geometry`'s depth check (it must outlive this) and the reference spacing, count and
  // mask margin of `options`.
  MapRecheck(const GeometricMasker& geometry, const DynamicMaskOptions& options);

  // The keyframe's mask with the moving pixels found against the earlier keyframes remembered
  // and the `later` ones (keyframes after it in time order, with their current poses; each
  // side spread by reference_spacing_s, reference_keyframes on each side), dilated by margin_px.
  // `later` references get their NearestStaticDepth cached. *changed: pixels were added.
  cv::Mat Recheck(double time, const cv::Mat& depth_m, const Eigen::Isometry3d& world_from_camera,
                  const cv::Mat& mask, const std::vector<MaskReference*>& later,
                  bool* changed) const;

  // Remembers a judged keyframe with its final pose and mask as an earlier reference for the
  // ones after it (references older than the options' horizon are forgotten).
  void Remember(MaskReference reference, bool mask_changed);

 private:
  const GeometricMasker& geometry_;
  DynamicMaskOptions options_;
  size_t max_references_;
  std::deque<MaskReference> recent_;  // oldest first
};

}  // namespace stillmap
