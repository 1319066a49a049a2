// How `stillmap merge` joins sessions: place recognition between every pair of sessions, each link
// verified geometrically, the links of a pair checked against each other, then one pose graph.
#pragma once

namespace stillmap {

struct MergeOptions {
  // Place recognition (tracking's place index over each session's keyframes): the keyframes of
  // another session with most votes, at least place_min_votes (tracking.place_min_votes), are
  // verified.
  int place_candidates = 3;
  int place_min_votes = 30;
  // Verification: ORB matches (best within max_descriptor_distance of 256 bits and below
  // match_ratio of the second best, Lowe's test), PnP-RANSAC on the candidate's points with depth,
  // then the RGB-D refinement: at least min_inliers inliers (tracking.loop_min_inliers).
  int max_descriptor_distance = 64;
  double match_ratio = 0.8;
  int min_inliers = 60;
  // The links between two sessions must agree on where one session lies in the other (the
  // pairwise consistency check of Kimera-RPGO, Mangelson et al.'s PCM): each link implies a
  // transform between the sessions' frames; the largest set that agrees within agreement_m
  // (where it puts the linked keyframes) and agreement_deg is kept, and the pair is joined only
  // when it holds min_links links. A look-alike place gives one or two links that agree with no
  // other.
  int min_links = 3;
  double agreement_m = 0.15;
  double agreement_deg = 5.0;
  // The pose graph: each keyframe is tied to the next one of its session and to up to
  // neighbour_edges others of its session within neighbour_radius_m (their final poses, which
  // the session's own bundle adjustment and loop closure settled); each kept link ties two
  // sessions, weighted link_weight against those edges.
  int neighbour_edges = 4;
  double neighbour_radius_m = 1.0;
  double link_weight = 1.0;
  // A keyframe is not fused when keyframes fused before it (of its session or an earlier one)
  // saw more than this share of its view's depth cells at the same depth (RevisitCells): the seed
  // paper's redundancy rule, with cells for the landmarks whose ids do not carry across sessions,
  // at the share of keyframes.max_shared_landmarks. 1 = off. bonn_crowd_a split in two: 1.052x
  // the whole build's voxels at 1 and 0.95, 1.039x at 0.9; a synthetic room in four sessions:
  // completeness 98.9 % at 1 and 0.95, 97.3 % at 0.9 (docs/figures.md).
  double max_seen_share = 0.9;

  // Throws InputError naming the key (merge.*) of the first impossible value.
  void Validate() const;

  // Every field under its configuration key (io/option_fields.h).
  template <typename Self, typename Visitor>
  static void VisitFields(Self& self, Visitor& visit) {
    visit("place_candidates", self.place_candidates,
          "best-voted keyframes of another session verified per keyframe");
    visit("place_min_votes", self.place_min_votes,
          "place index votes a keyframe needs to be verified as a candidate");
    visit("max_descriptor_distance", self.max_descriptor_distance,
          "largest Hamming distance of a match between sessions (of 256 bits)");
    visit("match_ratio", self.match_ratio, "best / second-best distance of a match (Lowe)");
    visit("min_inliers", self.min_inliers, "inliers of a verified link between two keyframes");
    visit("min_links", self.min_links, "agreeing verified links two sessions need to be joined");
    visit("agreement_m", self.agreement_m,
          "links agree when they place the linked keyframes within this of each other [m]");
    visit("agreement_deg", self.agreement_deg, "... and the sessions' frames within this [deg]");
    visit("neighbour_edges", self.neighbour_edges,
          "pose graph: edges from a keyframe to others of its session nearby");
    visit("neighbour_radius_m", self.neighbour_radius_m,
          "pose graph: keyframes of a session within this are nearby [m]");
    visit("link_weight", self.link_weight,
          "pose graph: weight of a link between sessions against a session's own edges");
    visit("max_seen_share", self.max_seen_share,
          "a keyframe is not fused when keyframes before it saw more than this share of its view "
          "(1 = off)");
  }
};

}  // namespace stillmap
