#include "stillmap/mapping/keyframe_selection.h"

#include <fmt/format.h>

#include "stillmap/io/error.h"
#include "stillmap/io/option_names.h"

namespace stillmap {

void KeyframeSelectionOptions::Validate() const {
  if (!(max_masked_share > 0.0 && max_masked_share <= 1.0)) {
    throw InputError(fmt::format("{} must be in (0, 1]", OptionKey(*this, max_masked_share)));
  }
  if (!(max_shared_landmarks > 0.0 && max_shared_landmarks <= 1.0)) {
    throw InputError(fmt::format("{} must be in (0, 1]", OptionKey(*this, max_shared_landmarks)));
  }
  revisit.Validate();
}

std::string KeyframeSelectionOptions::Describe() const {
  if (!enabled) return "off: every tracking keyframe is fused";
  std::string rule = fmt::format(
      "invalid when more than {} of the frame is masked; redundant when more than {} of its "
      "landmarks are seen by the keyframes selected before",
      max_masked_share, max_shared_landmarks);
  if (revisit.enabled) {
    rule += fmt::format(
        "; a keyframe fuses only the depth cells that fused keyframes made {} or more keyframes "
        "before it did not see at that depth from within {} degrees",
        revisit.keyframes_apart, revisit.view_angle_deg);
    if (revisit.max_seen_share < 1.0) {
      rule += fmt::format(", and none at all when they saw more than {} of its cells",
                          revisit.max_seen_share);
    }
  }
  if (revisit.segment_max_seen_share < 1.0) {
    rule += fmt::format(
        "; a keyframe of a map segment adds only its rays, no points, when other segments' "
        "keyframes saw more than {} of its cells at the final poses",
        revisit.segment_max_seen_share);
    if (revisit.segment_lap_path_m > 0.0) {
      rule += fmt::format(
          ", its own segment's keyframes counting too once its camera has travelled {} m since",
          revisit.segment_lap_path_m);
    }
  }
  return rule;
}

KeyframeSelector::KeyframeSelector(const KeyframeSelectionOptions& options) : options_(options) {}

KeyframeVerdict KeyframeSelector::Judge(double masked_share, const std::vector<int>& landmark_ids) {
  KeyframeVerdict verdict = KeyframeVerdict::kFused;
  if (options_.enabled) {
    size_t shared = 0;
    for (int id : landmark_ids) shared += selected_landmarks_.count(id);
    if (masked_share > options_.max_masked_share) {
      verdict = KeyframeVerdict::kInvalid;
    } else if (!landmark_ids.empty() &&
               static_cast<double>(shared) >
                   options_.max_shared_landmarks * static_cast<double>(landmark_ids.size())) {
      verdict = KeyframeVerdict::kRedundant;
    }
  }
  switch (verdict) {
    case KeyframeVerdict::kFused:
      ++fused_;
      selected_landmarks_.insert(landmark_ids.begin(), landmark_ids.end());
      break;
    case KeyframeVerdict::kInvalid:
      ++invalid_;
      break;
    case KeyframeVerdict::kRedundant:
      ++redundant_;
      break;
  }
  return verdict;
}

}  // namespace stillmap
