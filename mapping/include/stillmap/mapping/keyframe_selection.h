// Which keyframes are fused into the map: valid and not redundant (paper 000, section II.D).
#pragma once

#include <string>
#include <unordered_set>
#include <vector>

#include "stillmap/mapping/revisit_cells.h"

namespace stillmap {

struct KeyframeSelectionOptions {
  bool enabled = true;  // false: every keyframe is fused
  // Invalid: more of the frame masked as moving than this share (paper 000: 0.5).
  double max_masked_share = 0.5;
  // Redundant: |L n Lc| > this * |Lc|, with Lc the keyframe's landmarks and L those of the
  // keyframes selected before. Paper 000 uses 0.5; on synthetic walking_xyz (YOLOX) that fuses 4
  // of 23 keyframes and leaves 78.6 % completeness; 0.8 gives 85-92 % from run to run, 0.9 fuses
  // 16 of 24 for 98.0 % completeness and 0.34 % ghosts.
  double max_shared_landmarks = 0.9;
  // What a fused keyframe made on a revisit adds (revisit_cells.h).
  RevisitOptions revisit;

  // Throws InputError naming the key (keyframes.*) of the first impossible value.
  void Validate() const;
  // The rule in one sentence, for the report.
  std::string Describe() const;

  // Every field under its configuration key (io/option_fields.h).
  template <typename Self, typename Visitor>
  static void VisitFields(Self& self, Visitor& visit) {
    visit("enabled", self.enabled, "fuse only valid, non-redundant keyframes (paper 000)");
    visit("max_masked_share", self.max_masked_share,
          "invalid: a larger share of the frame is masked as moving (paper 000: 0.5)");
    visit("max_shared_landmarks", self.max_shared_landmarks,
          "redundant: more than this share of its landmarks is seen by the selected keyframes "
          "(paper 000: 0.5)");
    visit.Nested("revisit_", self.revisit);
  }
};

enum class KeyframeVerdict {
  kFused,      // valid and bringing new landmarks
  kInvalid,    // too much of the frame masked as moving
  kRedundant,  // its landmarks already seen by the keyframes selected before
};

// Judges keyframes in the order they are final and remembers the landmarks of those selected.
class KeyframeSelector {
 public:
  explicit KeyframeSelector(const KeyframeSelectionOptions& options);

  // The verdict on a keyframe with `masked_share` of its pixels masked as moving (0..1) that
  // observes `landmark_ids`; a fused keyframe's landmarks count for the next ones.
  KeyframeVerdict Judge(double masked_share, const std::vector<int>& landmark_ids);

  size_t fused() const { return fused_; }
  size_t invalid() const { return invalid_; }
  size_t redundant() const { return redundant_; }

 private:
  KeyframeSelectionOptions options_;
  std::unordered_set<int> selected_landmarks_;
  size_t fused_ = 0, invalid_ = 0, redundant_ = 0;
};

}  // namespace stillmap
