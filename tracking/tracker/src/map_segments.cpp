#include "stillmap/tracking/map_segments.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <stdexcept>

#include "stillmap/io/trajectory.h"

namespace stillmap {
namespace {

// The place index's hash masks come from this seed, so that a build repeats exactly.
constexpr std::uint64_t kSegmentPlaceSeed = 0x5e6e47;

}  // namespace

const char* SegmentJoinName(SegmentJoin join) {
  switch (join) {
    case SegmentJoin::kFirst:
      return "first";
    case SegmentJoin::kLinked:
      return "linked";
    case SegmentJoin::kNotJoined:
      return "not joined";
  }
  return "unknown";
}

MapSegments::MapSegments(const MapSegmentOptions& options)
    : options_(options),
      parked_(std::make_unique<SpillFile>("the map segments' places")),
      index_(std::in_place, options.place, kSegmentPlaceSeed) {}

int MapSegments::Begin(int first_keyframe_id, double time) {
  Segment segment;
  segment.first_keyframe = first_keyframe_id;
  segment.parent = static_cast<int>(segments_.size());
  segment.summary.id = segment.parent;
  segment.summary.first_time = segment.summary.last_time = time;
  segment.summary.join = segments_.empty() ? SegmentJoin::kFirst : SegmentJoin::kNotJoined;
  segments_.push_back(segment);
  return current();
}

int MapSegments::SegmentOf(int keyframe_id) const {
  for (int s = current(); s >= 0; --s) {
    if (segments_[static_cast<size_t>(s)].first_keyframe <= keyframe_id) return s;
  }
  return -1;
}

void MapSegments::AddFrame(double time) {
  if (segments_.empty()) return;
  SegmentSummary& summary = segments_.back().summary;
  ++summary.frames;
  summary.last_time = time;
}

int MapSegments::Root(int segment) const {
  while (segments_[static_cast<size_t>(segment)].parent != segment) {
    segment = segments_[static_cast<size_t>(segment)].parent;
  }
  return segment;
}

std::optional<SegmentCorrection> MapSegments::AddKeyframe(
    int keyframe_id, double time, const Eigen::Isometry3d& world_from_camera,
    std::vector<SessionFeature> features, int weakest_inliers) {
  if (!index_) throw std::logic_error("MapSegments::AddKeyframe after EndKeyframes");
  const int segment = SegmentOf(keyframe_id);
  if (segment < 0 || places_.count(keyframe_id) > 0) return std::nullopt;
  const LinkKeyframe keyframe(std::move(features));
  std::vector<unsigned char> bytes;
  AppendSessionFeatures(keyframe.features(), &bytes);
  places_.emplace(keyframe_id,
                  Place{segment, world_from_camera, parked_->Append(bytes), weakest_inliers});
  ++segments_[static_cast<size_t>(segment)].summary.keyframes;
  index_->Add(keyframe_id, keyframe.descriptors());
  const int root = Root(segment);
  if (segments_.size() < 2) return std::nullopt;  // nothing to link to
  const std::vector<PlaceCandidate> candidates =
      index_->Query(keyframe.descriptors(), static_cast<size_t>(options_.place_candidates),
                    [&](int id) { return places_.at(id).segment == segment; });
  for (const PlaceCandidate& candidate : candidates) {
    if (candidate.votes < options_.place_min_votes) break;  // ranked by votes
    ++candidates_;
    const Place& earlier = places_.at(candidate.keyframe_id);
    const LinkKeyframe earlier_keyframe(ParseSessionFeatures(parked_->Read(earlier.features)));
    const auto link = VerifyLink(earlier_keyframe, keyframe, options_.fx, options_.links);
    if (!link) continue;
    if (link->c_from_q.translation().norm() > options_.link_max_distance_m) {
      ++too_far_;
      continue;
    }
    links_.push_back({candidate.keyframe_id, keyframe_id, link->c_from_q});
    if (Root(earlier.segment) == root) return TakeLoop(links_.back(), root);
    return TryJoin(Root(earlier.segment), root, time);
  }
  return std::nullopt;
}

void MapSegments::Repose(const std::map<int, Eigen::Isometry3d>& world_from_keyframe) {
  for (auto& [id, place] : places_) {
    const auto it = world_from_keyframe.find(id);
    if (it != world_from_keyframe.end()) place.world_from_camera = it->second;
  }
}

std::optional<SegmentCorrection> MapSegments::TryJoin(int root_a, int root_b, double time) {
  const int older = std::min(root_a, root_b), younger = std::max(root_a, root_b);
  // Each link between the two groups, turned to run from the older group to the younger, and
  // the transform it implies (older world from younger world).
  std::vector<Link> between;
  std::vector<Eigen::Isometry3d> implied;
  std::vector<Eigen::Vector3d> positions;  // the linked keyframe of the younger group
  for (const Link& link : links_) {
    const Place& a = places_.at(link.keyframe_a);
    const Place& b = places_.at(link.keyframe_b);
    const int ra = Root(a.segment), rb = Root(b.segment);
    if (ra == older && rb == younger) {
      between.push_back(link);
    } else if (ra == younger && rb == older) {
      between.push_back({link.keyframe_b, link.keyframe_a, link.a_from_b.inverse()});
    } else {
      continue;
    }
    const Place& from = places_.at(between.back().keyframe_a);
    const Place& to = places_.at(between.back().keyframe_b);
    implied.push_back(from.world_from_camera * between.back().a_from_b *
                      to.world_from_camera.inverse());
    positions.push_back(to.world_from_camera.translation());
  }
  const LinkAgreement agreement = AgreeingLinks(implied, positions, options_.links);
  if (agreement.agreeing.size() < static_cast<size_t>(options_.links.min_links)) {
    return std::nullopt;
  }
  std::vector<Link> agreeing;
  for (size_t j : agreement.agreeing) agreeing.push_back(between[j]);
  taken_.insert(taken_.end(), agreeing.begin(), agreeing.end());
  SegmentCorrection correction = Join(older, younger, implied[agreement.centre], agreeing);
  SegmentSummary& summary = segments_[static_cast<size_t>(younger)].summary;
  summary.join = SegmentJoin::kLinked;
  summary.joined_to = places_.at(between[agreement.centre].keyframe_a).segment;
  summary.joined_time = time;
  summary.links = static_cast<int>(agreeing.size());
  return correction;
}

PoseGraphProblem MapSegments::ChainGraph(
    const std::function<std::optional<Eigen::Isometry3d>(const Place&)>& pose_of,
    const std::function<bool(int root, size_t node)>& held, const std::vector<Link>& links,
    std::vector<int>* ids) const {
  PoseGraphProblem problem;
  std::map<int, int> node_of;
  std::map<int, int> last_of_segment;  // segment -> its last node so far
  for (const auto& [id, place] : places_) {
    const std::optional<Eigen::Isometry3d> pose = pose_of(place);
    if (!pose) continue;
    const int node = static_cast<int>(ids->size());
    node_of[id] = node;
    ids->push_back(id);
    problem.world_from_node.push_back(*pose);
    problem.fixed.push_back(held(Root(place.segment), static_cast<size_t>(node)));
    const auto last = last_of_segment.find(place.segment);
    if (last != last_of_segment.end()) {
      problem.edges.push_back(EdgeBetween(
          last->second, node, problem.world_from_node[static_cast<size_t>(last->second)], *pose,
          OdometryEdgeWeight(place.weakest_inliers, options_.full_weight_inliers,
                             options_.min_weight)));
    }
    last_of_segment[place.segment] = node;
  }
  for (const Link& link : links) {
    const auto a = node_of.find(link.keyframe_a), b = node_of.find(link.keyframe_b);
    if (a == node_of.end() || b == node_of.end()) continue;
    problem.edges.push_back({a->second, b->second, link.a_from_b, options_.link_weight});
  }
  return problem;
}

std::map<int, Eigen::Isometry3d> MapSegments::SolveChainGraph(const PoseGraphProblem& problem,
                                                              const std::vector<int>& ids,
                                                              bool with_held) {
  const PoseGraphResult result = SolvePoseGraph(problem, options_.pose_graph);
  std::map<int, Eigen::Isometry3d> moved;
  for (size_t n = 0; n < ids.size(); ++n) {
    if (problem.fixed[n] && !with_held) continue;
    Place& place = places_.at(ids[n]);
    place.world_from_camera = result.world_from_node[n];
    moved.emplace(ids[n], place.world_from_camera);
  }
  return moved;
}

SegmentCorrection MapSegments::Join(int older, int younger,
                                    const Eigen::Isometry3d& older_from_younger,
                                    const std::vector<Link>& agreeing) {
  // The two groups' places: the older held, the younger moved rigidly first; each segment's
  // chain as its tracking had it, and the agreeing links.
  std::vector<int> ids;
  const PoseGraphProblem problem = ChainGraph(
      [&](const Place& place) -> std::optional<Eigen::Isometry3d> {
        const int root = Root(place.segment);
        if (root == older) return place.world_from_camera;
        if (root == younger) return older_from_younger * place.world_from_camera;
        return std::nullopt;
      },
      [older](int root, size_t) { return root == older; }, agreeing, &ids);
  SegmentCorrection correction;
  correction.rigid = older_from_younger;
  correction.world_from_keyframe = SolveChainGraph(problem, ids, false);
  for (const Segment& segment : segments_) {
    if (Root(segment.summary.id) == younger) correction.segments.push_back(segment.summary.id);
  }
  segments_[static_cast<size_t>(younger)].parent = older;
  return correction;
}

std::optional<SegmentCorrection> MapSegments::TakeLoop(const Link& link, int root) {
  const Place& a = places_.at(link.keyframe_a);
  const Place& b = places_.at(link.keyframe_b);
  // Where the link puts b, against where the group has it.
  const Eigen::Isometry3d b_moved = a.world_from_camera * link.a_from_b;
  const Eigen::Isometry3d change = b.world_from_camera.inverse() * b_moved;
  const double degrees = RotationAngleDeg(change);
  if (change.translation().norm() > options_.loop_max_m || degrees > options_.loop_max_deg) {
    return std::nullopt;  // a look-alike place, or more drift than a loop corrects
  }
  taken_.push_back(link);
  ++loop_links_;
  if (++loops_since_settle_ < static_cast<size_t>(options_.settle_after_loops)) return std::nullopt;
  return Settle(root);
}

SegmentCorrection MapSegments::Settle(int root) {
  loops_since_settle_ = 0;
  ++settles_;
  std::vector<int> ids;
  const PoseGraphProblem problem = ChainGraph(
      [&](const Place& place) -> std::optional<Eigen::Isometry3d> {
        if (Root(place.segment) != root) return std::nullopt;
        return place.world_from_camera;
      },
      [](int, size_t node) { return node == 0; }, taken_, &ids);
  SegmentCorrection correction;
  correction.world_from_keyframe = SolveChainGraph(problem, ids, true);
  for (const Segment& segment : segments_) {
    if (Root(segment.summary.id) == root) correction.segments.push_back(segment.summary.id);
  }
  return correction;
}

std::map<int, Eigen::Isometry3d> MapSegments::SettleLastLoops() {
  std::map<int, Eigen::Isometry3d> moved;
  if (loops_since_settle_ == 0) return moved;
  for (const Segment& segment : segments_) {
    const int root = segment.summary.id;
    if (Root(root) != root) continue;
    const bool grouped = std::any_of(segments_.begin(), segments_.end(), [&](const Segment& other) {
      return other.summary.id != root && Root(other.summary.id) == root;
    });
    if (!grouped) continue;
    const SegmentCorrection correction = Settle(root);
    moved.insert(correction.world_from_keyframe.begin(), correction.world_from_keyframe.end());
  }
  return moved;
}

std::vector<SegmentSummary> MapSegments::Summaries() const {
  std::vector<SegmentSummary> out;
  for (const Segment& segment : segments_) {
    out.push_back(segment.summary);
    out.back().in_map = InMap(segment.summary.id);
  }
  return out;
}

size_t MapSegments::MemoryBytes() const {
  size_t bytes = index_ ? index_->MemoryBytes() : 0;
  // The map's nodes: four pointers beside the key and the place (an estimate).
  bytes += places_.size() * (sizeof(std::pair<const int, Place>) + 4 * sizeof(void*));
  return bytes;
}

}  // namespace stillmap
