// The options and figures of the keyframes' final pose refinement by dense alignment
// (dense_refinement.h).
#pragma once

namespace stillmap {

struct DenseRefinementOptions {
  bool enabled = true;
  int next_keyframes = 2;       // each keyframe aligned to this many after it
  double max_next_gap_s = 3.0;  // ... at most this much later [s]
  // Each keyframe is also aligned to this many keyframes of another time (at least
  // revisit_min_gap_s before it) whose cameras are within revisit_max_distance_m and whose optical
  // axes are within revisit_max_angle_deg. A floor's route passes most places once each way, so
  // few keyframes have such a partner (floor_lost seed 2: 83 of 715 within 0.5 m): at 4 pairs
  // within 1 m, and alignments taken up to 0.2 m (below), floor_lost seed 2's cloud within 3 cm
  // of the truth went from 86.4 to 89.4 %, floor seed 1's from 94.7 to 95.2 %, floor seed 2's
  // 98.7 to 98.5 %, floor_lost seed 1's 97.4 to 97.0 %; the synthetic rooms, TUM teddy and
  // bonn_crowd_a came out the same bytes (docs/figures.md, seventy-third session).
  int revisit_pairs = 4;
  double revisit_min_gap_s = 10.0;      // "another time": at least this long before [s]
  double revisit_max_distance_m = 1.0;  // cameras at most this far apart [m]
  double revisit_max_angle_deg = 20.0;  // ... and their optical axes this far [deg]
  // An alignment of a keyframe to the next ones that moves the pair from its poses by more is
  // not taken [m], or that turns it more [deg]; for keyframes of another time, where the drift
  // in between is what the alignment measures, revisit_max_change_*.
  double max_change_m = 0.01;
  double max_change_deg = 0.3;
  double revisit_max_change_m = 0.2;
  double revisit_max_change_deg = 3.0;
  // A triangle of alignments to the next keyframes (a to b, b to c, a to c) closes when going
  // round it comes back within this [m] and [deg]; an alignment whose triangles all stay open
  // is not taken. On the synthetic floor (seed 1) 18 of the 1285 alignments so taken were more
  // than 5 mm or 0.1 degrees off the truth, against 37 of 1288 by the change alone; in TUM
  // teddy no triangle closed (docs/figures.md).
  double cycle_max_m = 0.003;
  double cycle_max_deg = 0.05;
  // An alignment's noise against the poses' shape (the pose graph's 0.01 m) [m].
  double alignment_sigma_m = 0.002;
  // Each keyframe may also be held to where the poses put it in the map, as sure as this [m]
  // (0: not held). Held at 5 cm (the fifty-third to sixty-first sessions' choice) the feature
  // poses' scale, 0.2-0.4 % short on the floors, stays; the spans below keep what it kept
  // (docs/figures.md, sixty-second session).
  double prior_sigma_m = 0.0;
  // Each keyframe is also held to the keyframes 2, 4, 8 ... max_span_keyframes after it at the
  // relative pose the poses give, as sure as span_sigma_m plus span_drift_share of the path
  // between them (0: no such edge): a stretch where the alignments' chain is broken cannot
  // swing what follows (floor seed 2 lost a segment's place without), while a drift the
  // alignments measure along the path (the feature poses' scale) is free to go. The feature
  // keyframes' relative poses on the floor are 5 mm and 0.05 degrees off at one keyframe, 11 mm
  // and 0.34 degrees at 2.8 m of path (docs/figures.md).
  double span_drift_share = 0.03;
  double span_sigma_m = 0.005;
  // ... and their relative rotation as sure as span_rotation_sigma_deg plus
  // span_rotation_drift_deg_per_m of the path between them.
  double span_rotation_sigma_deg = 0.05;
  double span_rotation_drift_deg_per_m = 0.1;
  int max_span_keyframes = 64;
  // Where tracking began anew between two keyframes (a relocalization, a new segment's start),
  // their relative pose was not tracked frame to frame: the edges over that step (the
  // consecutive one and the spans) are as sure as their own sigma plus this in translation [m]
  // (0: as any other step), so that the alignments and the revisits place what follows. Within
  // 3 cm of the truth: floor seed 2 97.56 -> 98.25 %, floor_lost seed 1 95.95 -> 97.33 %; the
  // rooms the same bytes (docs/figures.md, sixty-fourth session).
  double anew_sigma_m = 0.05;
  int cell_px = 4;  // the images are averaged over cells this wide [px]
  // Each pair is first aligned on cells this wide [px] (0: not), from the poses, and then on
  // cell_px from there where that alignment was taken: in a blank corridor a start 5-10 cm off
  // slides the fine alignment along the walls into a wrong minimum, which the coarse one
  // escapes (floor seed 2's new segment at 1117.3 s: of 11 pairs, 9 within 10 mm of the truth
  // at 8 px against 3 at 4 px). Not by default: at 8 px the floors' clouds came out 0.2-0.3
  // points less within 3 cm of the truth (docs/figures.md, sixty-ninth session).
  int coarse_cell_px = 0;
  // A frame between keyframes takes their corrections averaged over this (a Gaussian's width)
  // [s] (0: interpolated between the two keyframes on either side). The corrections are taken
  // against the frames' own smoothed poses at the keyframes' stamps, where the keyframes start
  // from. Interpolated, the floors gained most, but a room's frames (walking_xyz without the
  // models: +0.9 mm) took the keyframes' own corrections, which are not theirs; over 3 s the
  // rooms stay within 0.3 mm and the floors keep most of the gain (docs/figures.md,
  // sixty-second session).
  double frame_smoothing_s = 3.0;

  void Validate() const;  // throws InputError naming the key

  template <typename Self, typename Visitor>
  static void VisitFields(Self& self, Visitor& visit) {
    visit("dense_enabled", self.enabled,
          "refine the keyframes' final poses by dense alignment of pairs of them");
    visit("dense_next_keyframes", self.next_keyframes,
          "each keyframe is aligned to this many keyframes after it");
    visit("dense_max_next_gap_s", self.max_next_gap_s, "... at most this much later [s]");
    visit("dense_revisit_pairs", self.revisit_pairs,
          "each keyframe is aligned to this many keyframes of another time with its view");
    visit("dense_revisit_min_gap_s", self.revisit_min_gap_s,
          "... made at least this long before it [s]");
    visit("dense_revisit_max_distance_m", self.revisit_max_distance_m,
          "... whose camera is at most this far [m]");
    visit("dense_revisit_max_angle_deg", self.revisit_max_angle_deg,
          "... and whose optical axis is at most this far turned [deg]");
    visit("dense_max_change_m", self.max_change_m,
          "an alignment to the next keyframes moving the pair from its poses by more is not "
          "taken [m]");
    visit("dense_max_change_deg", self.max_change_deg, "... or turning it more [deg]");
    visit("dense_revisit_max_change_m", self.revisit_max_change_m,
          "an alignment to a keyframe of another time moving the pair by more is not taken [m]");
    visit("dense_revisit_max_change_deg", self.revisit_max_change_deg,
          "... or turning it more [deg]");
    visit("dense_cycle_max_m", self.cycle_max_m,
          "a triangle of alignments to the next keyframes closes within this [m]");
    visit("dense_cycle_max_deg", self.cycle_max_deg, "... and this [deg]");
    visit("dense_alignment_sigma_m", self.alignment_sigma_m,
          "an alignment's noise in the pose graph (the poses' shape: 0.01 m) [m]");
    visit("dense_prior_sigma_m", self.prior_sigma_m,
          "each keyframe is held to its pose as sure as this (0: not held) [m]");
    visit("dense_span_drift_share", self.span_drift_share,
          "each keyframe is held to the ones 2, 4, 8 ... after it as sure as this share of the "
          "path between them (0: not held) [m/m]");
    visit("dense_span_sigma_m", self.span_sigma_m, "... plus this [m]");
    visit("dense_span_rotation_sigma_deg", self.span_rotation_sigma_deg,
          "... and their relative rotation as sure as this [deg]");
    visit("dense_span_rotation_drift_deg_per_m", self.span_rotation_drift_deg_per_m,
          "... plus this per metre of path between them [deg/m]");
    visit("dense_max_span_keyframes", self.max_span_keyframes,
          "... up to this many keyframes after it");
    visit("dense_anew_sigma_m", self.anew_sigma_m,
          "where tracking began anew between two keyframes (relocalized, a new segment), the "
          "edges over that step are as sure as their own sigma plus this (0: as any step) [m]");
    visit("dense_cell_px", self.cell_px, "images are averaged over cells this wide [px]");
    visit("dense_coarse_cell_px", self.coarse_cell_px,
          "each pair is first aligned on cells this wide, then on dense_cell_px from there "
          "(0: not) [px]");
    visit("dense_frame_smoothing_s", self.frame_smoothing_s,
          "a frame between keyframes takes their corrections averaged over this (0: "
          "interpolated) [s]");
  }
};

struct DenseRefinementFigures {
  size_t keyframes = 0;
  size_t next_pairs = 0, next_taken = 0;
  size_t revisit_pairs = 0, revisit_taken = 0;
  double largest_move_m = 0.0;  // of a keyframe, by the refinement
  double ms = 0.0;
};

}  // namespace stillmap
