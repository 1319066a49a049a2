// Place recognition and loop closure as a component of their own, behind a narrow interface:
// keyframes in (their descriptors; their poses and shared landmarks as the tracker's map has
// them), candidates, accepted loops and pose-graph corrections out. It owns the place index and
// the loop's consistency state; verifying a candidate (matching a keyframe against the
// candidate's landmarks) stays with the tracker, which owns the landmarks.
#pragma once

#include <Eigen/Geometry>
#include <algorithm>
#include <climits>
#include <cstdint>
#include <exception>
#include <limits>
#include <map>
#include <opencv2/core.hpp>
#include <utility>
#include <vector>

#include "stillmap/tracking/place_index.h"
#include "stillmap/tracking/pose_graph.h"

namespace stillmap {

// Place recognition (place_index.h) and loop closure (issue 27). Every keyframe's descriptors
// go into the place index; a relocalization verifies the place_candidates keyframes with most
// votes (at least place_min_votes) besides the most recent ones. Each new keyframe asks the
// index for an earlier place it does not share landmarks with (at least loop_min_separation
// keyframes older); a candidate is verified geometrically (at least loop_min_inliers inliers),
// and a loop is accepted only when loop_consistency keyframes in a row verify the same place.
// The pose graph over all keyframes (odometry edges, covisibility edges between keyframes
// sharing pose_graph_min_shared landmarks, the loop edge) is solved on the bundle adjustment's
// worker and taken loop_handover_frames later; a global bundle adjustment follows, taken
// global_bundle_adjustment_handover_frames later.
struct LoopClosureOptions {
  PlaceIndexOptions place;
  int place_candidates = 3;
  int place_min_votes = 30;
  bool loop_closure = true;
  int loop_min_inliers = 60;
  int loop_consistency = 2;
  int loop_min_separation = 10;
  int pose_graph_min_shared = 100;
  // An odometry edge (a keyframe and the one before it) is as sure as the weakest frame tracked
  // between them: full weight when every frame had pose_graph_full_weight_inliers inliers,
  // (fewest / that)^2 below, and pose_graph_min_weight across frames that were lost or posed by
  // the motion model. A loop's correction then goes where tracking was weak (a person across
  // the lens in a corridor) instead of being spread evenly over the loop.
  int pose_graph_full_weight_inliers = 120;
  double pose_graph_min_weight = 0.001;
  PoseGraphOptions pose_graph;
  int loop_handover_frames = 5;
  bool loop_global_bundle_adjustment = true;
  int global_bundle_adjustment_handover_frames = 30;
  // A verified loop whose correction exceeds what drift could do over the path between its two
  // keyframes is refused (a look-alike place). stillmap drifts about 1 % of the path (teddy,
  // bonn_crowd_a, the synthetic loop).
  double loop_max_drift_m = 0.1;
  double loop_max_drift_share = 0.05;
  double loop_max_drift_deg = 3.0;
  double loop_max_drift_deg_per_m = 1.0;

  // Throws InputError naming the first impossible value.
  void Validate() const;

  // Every field under its configuration key (io/option_fields.h).
  template <typename Self, typename Visitor>
  static void VisitFields(Self& self, Visitor& visit) {
    visit.Nested("place_", self.place);
    visit("place_candidates", self.place_candidates,
          "best-voted keyframes of the place index verified per query");
    visit("place_min_votes", self.place_min_votes,
          "place index votes a keyframe needs to be verified as a candidate");
    visit("loop_closure", self.loop_closure,
          "detect loops with the place index and correct them with the pose graph");
    visit("loop_min_inliers", self.loop_min_inliers,
          "inliers of a keyframe's pose against an earlier place for a verified loop");
    visit("loop_consistency", self.loop_consistency,
          "keyframes in a row that must verify the same place before a loop is accepted");
    visit("loop_min_separation", self.loop_min_separation,
          "a loop candidate is at least this many keyframes older than the keyframe");
    visit("pose_graph_min_shared", self.pose_graph_min_shared,
          "landmarks two keyframes share for a covisibility edge of the pose graph");
    visit("pose_graph_full_weight_inliers", self.pose_graph_full_weight_inliers,
          "pose graph: an odometry edge has full weight when every frame between its keyframes "
          "had this many inliers, (fewest / this)^2 below");
    visit("pose_graph_min_weight", self.pose_graph_min_weight,
          "pose graph: weight of an odometry edge across lost frames (and the least of any)");
    visit.Nested("pose_graph_", self.pose_graph);
    visit("loop_handover_frames", self.loop_handover_frames,
          "frames after a loop is accepted when its pose graph's result is taken");
    visit("loop_global_bundle_adjustment", self.loop_global_bundle_adjustment,
          "after a loop correction, bundle-adjust the whole local map on the worker");
    visit("global_bundle_adjustment_handover_frames", self.global_bundle_adjustment_handover_frames,
          "frames after its request when the global bundle adjustment's result is taken");
    visit("loop_max_drift_m", self.loop_max_drift_m,
          "a loop's correction may be this much [m] ...");
    visit("loop_max_drift_share", self.loop_max_drift_share,
          "... plus this share of the path between its keyframes (else refused as a look-alike)");
    visit("loop_max_drift_deg", self.loop_max_drift_deg,
          "a loop's rotation correction may be this much [deg] ...");
    visit("loop_max_drift_deg_per_m", self.loop_max_drift_deg_per_m,
          "... plus this much per metre of path between its keyframes [deg/m]");
  }
};

// A loop's pose graph and, once solved, its result (LoopClosure::Correction).
struct LoopCorrection {
  PoseGraphProblem problem;  // read by the solver; its initial poses give each correction
  std::vector<int> ids;      // keyframe id per node, ascending
  int keyframe_id = 0;       // the keyframe that closed the loop
  int candidate = 0;         // the earlier place's keyframe
  std::vector<std::pair<size_t, int>> merges;  // (feature of keyframe_id, earlier landmark)
  size_t handover_serial = 0;                  // taken before the frame with this serial
  bool is_solved = false;
  PoseGraphResult result;
  std::exception_ptr error;
  double ms = 0.0;
};

class LoopClosure {
 public:
  LoopClosure(const LoopClosureOptions& options, std::uint64_t seed);

  const LoopClosureOptions& options() const { return options_; }

  // Keyframes in: a keyframe's descriptors become a place; a culled or dropped one leaves.
  void AddPlace(int keyframe_id, const cv::Mat& descriptors) {
    places_.Add(keyframe_id, descriptors);
  }
  void RemovePlace(int keyframe_id) { places_.Remove(keyframe_id); }
  size_t MemoryBytes() const { return places_.MemoryBytes(); }

  // Candidates out, for a relocalization: the best-voted places (at least place_min_votes).
  std::vector<int> RelocalizationCandidates(const cv::Mat& descriptors) const;

  // Candidates out, for a loop: places at least loop_min_separation keyframes older than
  // `keyframe_id` that share no landmarks with it (`shared`: keyframe -> landmarks shared) and
  // look at least as much like it as the least alike of its well-connected neighbours (as
  // ORB-SLAM2); `usable` says whether a keyframe can still be verified. Best-voted first.
  template <typename Usable>
  std::vector<int> LoopCandidates(int keyframe_id, const cv::Mat& descriptors,
                                  const std::map<int, int>& shared, Usable&& usable) const;

  // Whether a loop's correction (`correction`: where the keyframe is against where the loop puts
  // it) is within what drift could do over `path_m` of path between its two keyframes.
  bool PlausibleDrift(double path_m, const Eigen::Isometry3d& correction) const;

  // Links in: the place a new keyframe verified (-1: none), and whether it is the same place the
  // previous keyframe verified. True when the loop is accepted (loop_consistency in a row).
  bool AcceptVerified(int verified, bool same_place_as_last);
  // The place the last verification found; whether a streak of them is under way.
  int last_candidate() const { return last_candidate_; }
  bool in_streak() const { return streak_ > 0; }

  // Corrections out: the pose graph over every keyframe (`world_from_keyframe`, by id: odometry
  // edges in id order, the oldest fixed, each weighted by `weakest_inliers`: per keyframe, the
  // fewest inliers of a frame tracked since the keyframe before, 0 when one was not), covisibility
  // edges between keyframes sharing pose_graph_min_shared landmarks (`shared_pairs`: (older,
  // newer) -> landmarks), and the loop edge: `keyframe_id` at `world_from_loop_pose` as verified
  // against `candidate`.
  LoopCorrection PrepareCorrection(const std::map<int, Eigen::Isometry3d>& world_from_keyframe,
                                   const std::map<int, int>& weakest_inliers,
                                   const std::map<std::pair<int, int>, int>& shared_pairs,
                                   int keyframe_id, int candidate,
                                   const Eigen::Isometry3d& world_from_loop_pose) const;
  // Solves the pose graph into `correction` (its result, error and time).
  void Solve(LoopCorrection* correction) const;
  // Per keyframe id of the graph: world' = correction * world.
  static std::map<int, Eigen::Isometry3d> Corrections(const LoopCorrection& correction);
  // The weight of an odometry edge whose frames had at fewest `weakest_inliers`.
  double OdometryWeight(int weakest_inliers) const;

 private:
  LoopClosureOptions options_;
  PlaceIndex places_;
  int streak_ = 0;           // keyframes in a row that verified the same earlier place
  int last_candidate_ = -1;  // the place the last of them verified
};

template <typename Usable>
std::vector<int> LoopClosure::LoopCandidates(int keyframe_id, const cv::Mat& descriptors,
                                             const std::map<int, int>& shared,
                                             Usable&& usable) const {
  const std::vector<PlaceCandidate> voted =
      places_.Query(descriptors, std::numeric_limits<size_t>::max(), [](int) { return false; });
  // An earlier place must look at least as much like this view as the least alike of the
  // keyframes that share kWellConnected landmarks with it.
  constexpr int kWellConnected = 30;
  int min_votes = options_.place_min_votes, least_alike = INT_MAX;
  for (const PlaceCandidate& candidate : voted) {
    const auto it = shared.find(candidate.keyframe_id);
    if (candidate.keyframe_id != keyframe_id && it != shared.end() &&
        it->second >= kWellConnected) {
      least_alike = std::min(least_alike, candidate.votes);
    }
  }
  if (least_alike != INT_MAX) min_votes = std::max(min_votes, least_alike);
  std::vector<int> candidates;
  for (const PlaceCandidate& candidate : voted) {
    if (candidate.votes < min_votes) break;  // ranked by votes
    const int id = candidate.keyframe_id;
    if (id > keyframe_id - options_.loop_min_separation || shared.count(id) > 0) continue;
    if (!usable(id)) continue;
    candidates.push_back(id);
    if (candidates.size() >= static_cast<size_t>(options_.place_candidates)) break;
  }
  return candidates;
}

}  // namespace stillmap
