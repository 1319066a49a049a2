// Map segments (issue 47): when tracking is lost and relocalization does not undo it, the
// tracker starts a new local map whose place relative to the earlier ones is unknown: a new
// segment, in a frame of its own. A component of its own behind a narrow interface: keyframes in
// (final keyframes with their features and poses, and where each segment begins); segments,
// links and corrections out. Each keyframe becomes a place of its segment and asks the place index
// for places of the segments not joined with its own; each candidate is verified geometrically
// (place_links.h) and the links between two groups of segments are checked against each other
// with the merge's rule (min_links links agreeing on where one group lies in the other). Then the
// younger group is joined to the older: moved by the links' transform, and settled by a pose graph
// (its own keyframes' chain and the agreeing links, the older group held). Links found later
// between segments of one group are loops: the group's pose graph (every segment's chain, every
// link) is solved again over them. The group of the first segment is the map; a segment never
// joined to it is written apart by the build.
#pragma once

#include <Eigen/Geometry>
#include <climits>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "stillmap/io/session_record.h"
#include "stillmap/io/spill_file.h"
#include "stillmap/tracking/place_index.h"
#include "stillmap/tracking/place_links.h"
#include "stillmap/tracking/pose_graph.h"

namespace stillmap {

struct MapSegmentOptions {
  PlaceIndexOptions place;      // tracking.place_*
  int place_candidates = 3;     // best-voted places verified per keyframe (merge.*)
  int place_min_votes = 30;     // votes a place needs to be verified (merge.*)
  PlaceLinkOptions links;       // verification and agreement (merge.*)
  PoseGraphOptions pose_graph;  // tracking.pose_graph_*
  double link_weight = 1.0;     // a link's edge against a segment's own (merge.link_weight)
  // A verified link between cameras farther apart than this is not used [m]: seen from afar, a
  // place's features lie in a narrow cone and the link's turn and shift trade off against each
  // other. On the synthetic floor, links under 1 m were off by 4 mm (median, at most 12 mm),
  // links over 1 m by 70-144 mm (median, up to 608 mm) (docs/figures.md).
  double link_max_distance_m = 1.0;
  // A segment's own edge between two places is as sure as the weakest frame tracked between
  // them (OdometryEdgeWeight; tracking.pose_graph_full_weight_inliers and _min_weight).
  int full_weight_inliers = 120;
  double min_weight = 0.001;
  // Once joined, a link between two segments of a group is a loop: taken when it asks for no more
  // than this correction (drift, not a look-alike place), and every settle_after_loops of them
  // the group's pose graph is solved again with all its links.
  double loop_max_m = 0.5;
  double loop_max_deg = 5.0;
  int settle_after_loops = 5;
  double fx = 525.0;  // the camera's focal length [px]: the features' pixel noise
};

enum class SegmentJoin {
  kFirst,      // the first segment: the map
  kLinked,     // joined to an earlier segment by agreeing links
  kNotJoined,  // never placed: written apart
};
const char* SegmentJoinName(SegmentJoin join);

struct SegmentSummary {
  int id = 0;
  double first_time = 0.0, last_time = 0.0;  // its first and last tracked frame [s]
  size_t frames = 0;                         // tracked frames
  size_t keyframes = 0;                      // final keyframes it holds (not culled)
  SegmentJoin join = SegmentJoin::kNotJoined;
  int joined_to = -1;        // the segment its links went to
  double joined_time = 0.0;  // the time of the keyframe whose link joined it [s]
  int links = 0;             // the agreeing links that joined it
  bool in_map = false;       // in the first segment's group (by now)
};

// What place recognition between segments did.
struct SegmentLinkFigures {
  size_t candidates = 0;  // places of other segments verified
  size_t verified = 0;    // of them, verified links used (within link_max_distance_m)
  size_t too_far = 0;     // verified, but left out: cameras farther apart than that
  size_t loops = 0;       // links within a group taken as loops
  size_t settles = 0;     // the group's pose graph solved again over its loops
};

// A join: the new poses (camera-to-world) of the keyframes of the segments that moved.
struct SegmentCorrection {
  std::vector<int> segments;  // the segments that moved
  std::map<int, Eigen::Isometry3d> world_from_keyframe;
  Eigen::Isometry3d rigid = Eigen::Isometry3d::Identity();  // world' = rigid * world, before
                                                            // the pose graph settled it
};

class MapSegments {
 public:
  explicit MapSegments(const MapSegmentOptions& options);

  // A segment begins with its first keyframe (the first map, or a new one after a loss).
  int Begin(int first_keyframe_id, double time);
  int current() const { return static_cast<int>(segments_.size()) - 1; }
  // The segment a keyframe belongs to (keyframe ids increase with time); -1 before the first.
  int SegmentOf(int keyframe_id) const;
  // A tracked frame of the current segment.
  void AddFrame(double time);

  // A final keyframe (not culled) with its pose and features: a place of its segment;
  // `weakest_inliers` (FinalKeyframe's) weighs the step from the segment's place before it.
  // Returns a correction when its link joins two groups.
  std::optional<SegmentCorrection> AddKeyframe(int keyframe_id, double time,
                                               const Eigen::Isometry3d& world_from_camera,
                                               std::vector<SessionFeature> features,
                                               int weakest_inliers);
  // After the last keyframe: when loops were taken since the last settle, every group of
  // several segments is settled again (a settle otherwise waits for settle_after_loops of them).
  // Returns the places that moved (empty: none).
  std::map<int, Eigen::Isometry3d> SettleLastLoops();
  // After the last keyframe: the place index, which only new keyframes query, is freed (a floor's
  // is tens of MiB). AddKeyframe throws std::logic_error after this.
  void EndKeyframes() { index_.reset(); }
  // Keyframe poses moved (the tracker's bundle adjustment or loops): the places follow.
  void Repose(const std::map<int, Eigen::Isometry3d>& world_from_keyframe);

  // The segment is in the first segment's group: its keyframes belong in the map.
  bool InMap(int segment) const { return Root(segment) == 0; }
  std::vector<SegmentSummary> Summaries() const;
  SegmentLinkFigures figures() const {
    return {candidates_, links_.size(), too_far_, loop_links_, settles_};
  }
  size_t MemoryBytes() const;

 private:
  struct Segment {
    int first_keyframe = 0;
    int parent = 0;  // union-find: the group's root is its oldest segment
    SegmentSummary summary;
  };
  struct Place {
    int segment = 0;
    Eigen::Isometry3d world_from_camera;
    // Its features (AppendSessionFeatures) in parked_: read back only to verify a link, so that
    // the places of a long recording are not all in memory.
    SpillFile::Block features;
    int weakest_inliers = INT_MAX;  // of the frames since the segment's place before
  };
  struct Link {
    int keyframe_a = 0, keyframe_b = 0;  // a: the earlier place, b: the keyframe that asked
    Eigen::Isometry3d a_from_b = Eigen::Isometry3d::Identity();
  };

  int Root(int segment) const;
  // The verified links between the groups of `a` and `b` that agree; a join when enough do.
  std::optional<SegmentCorrection> TryJoin(int root_a, int root_b, double time);
  // Moves the younger group onto the older by `older_from_younger`, then settles it with a pose
  // graph; returns its keyframes' new poses.
  SegmentCorrection Join(int older, int younger, const Eigen::Isometry3d& older_from_younger,
                         const std::vector<Link>& agreeing);
  // The pose graph over the places `pose_of` gives a pose (nothing: left out): each segment's
  // chain of places at those poses, and `links` between two of them; `held(root, node)` says
  // which nodes stay. *ids gets the places in node order.
  PoseGraphProblem ChainGraph(
      const std::function<std::optional<Eigen::Isometry3d>(const Place&)>& pose_of,
      const std::function<bool(int root, size_t node)>& held, const std::vector<Link>& links,
      std::vector<int>* ids) const;
  // Solves it and moves the places not held (and the held ones too, `with_held`) to the result;
  // returns their new poses by keyframe id.
  std::map<int, Eigen::Isometry3d> SolveChainGraph(const PoseGraphProblem& problem,
                                                   const std::vector<int>& ids, bool with_held);
  // A link between two segments of one group: a loop when it asks for little correction, and the
  // group settled again when enough have come.
  std::optional<SegmentCorrection> TakeLoop(const Link& link, int root);
  // The pose graph of the group `root`: every segment's chain and every link taken, its first
  // place held. Returns the places that moved.
  SegmentCorrection Settle(int root);

  MapSegmentOptions options_;
  std::vector<Segment> segments_;
  std::map<int, Place> places_;  // by keyframe id
  std::unique_ptr<SpillFile> parked_;
  std::optional<PlaceIndex> index_;  // none after EndKeyframes
  std::vector<Link> links_;          // every verified link
  std::vector<Link> taken_;          // the links of joins and the loops: the pose graphs' edges
  size_t candidates_ = 0, too_far_ = 0;
  size_t loop_links_ = 0, loops_since_settle_ = 0, settles_ = 0;
};

}  // namespace stillmap
