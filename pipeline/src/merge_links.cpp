#include "merge_links.h"

namespace stillmap {
namespace {

// The place index's hash masks come from this seed, so that a merge repeats exactly.
constexpr std::uint64_t kPlaceSeed = 0x5e55105;

// Keyframe q (of b) in the frame of keyframe c (of a) (place_links.h).
std::optional<SessionLink> Verify(const SessionPlaces& a, int c, const SessionPlaces& b, int q,
                                  const MergeOptions& options) {
  const auto link =
      VerifyLink(a.keyframe(static_cast<size_t>(c)), b.keyframe(static_cast<size_t>(q)),
                 b.record().camera.fx, LinkOptions(options));
  if (!link) return std::nullopt;
  return SessionLink{c, q, link->c_from_q, link->inliers};
}

// Where the link puts session b's frame in session a's.
Eigen::Isometry3d Implied(const SessionLink& link, const SessionRecord& a, const SessionRecord& b) {
  return a.keyframes[static_cast<size_t>(link.keyframe_a)].map_from_camera * link.a_from_b *
         b.keyframes[static_cast<size_t>(link.keyframe_b)].map_from_camera.inverse();
}

// The largest set of links that agree on where b lies in a (place_links.h).
void KeepAgreeing(const SessionRecord& a, const SessionRecord& b, const MergeOptions& options,
                  const std::vector<SessionLink>& links, PairLinks* pair) {
  if (links.empty()) return;
  std::vector<Eigen::Isometry3d> implied;
  std::vector<Eigen::Vector3d> positions;
  for (const SessionLink& link : links) {
    implied.push_back(Implied(link, a, b));
    positions.push_back(
        b.keyframes[static_cast<size_t>(link.keyframe_b)].map_from_camera.translation());
  }
  const LinkAgreement agreement = AgreeingLinks(implied, positions, LinkOptions(options));
  for (size_t j : agreement.agreeing) pair->agreeing.push_back(links[j]);
  pair->a_map_from_b_map = implied[agreement.centre];
  pair->joined = pair->agreeing.size() >= static_cast<size_t>(options.min_links);
}

}  // namespace

PlaceLinkOptions LinkOptions(const MergeOptions& options) {
  PlaceLinkOptions link;
  link.max_descriptor_distance = options.max_descriptor_distance;
  link.match_ratio = options.match_ratio;
  link.min_inliers = options.min_inliers;
  link.min_links = options.min_links;
  link.agreement_m = options.agreement_m;
  link.agreement_deg = options.agreement_deg;
  return link;
}

SessionPlaces::SessionPlaces(const SessionRecord& record, const PlaceIndexOptions& index_options)
    : record_(record), index_(index_options, kPlaceSeed) {
  for (size_t k = 0; k < record.keyframes.size(); ++k) {
    keyframes_.emplace_back(record.keyframes[k].features);
    index_.Add(static_cast<int>(k), keyframes_.back().descriptors());
  }
}

PairLinks FindLinks(const SessionPlaces& a, const SessionPlaces& b, int index_a, int index_b,
                    const MergeOptions& options) {
  PairLinks pair;
  pair.session_a = index_a;
  pair.session_b = index_b;
  std::vector<SessionLink> verified;
  for (size_t q = 0; q < b.record().keyframes.size(); ++q) {
    const std::vector<PlaceCandidate> candidates =
        a.index().Query(b.keyframe(q).descriptors(), static_cast<size_t>(options.place_candidates),
                        [](int) { return false; });
    for (const PlaceCandidate& candidate : candidates) {
      if (candidate.votes < options.place_min_votes) break;  // ranked by votes
      ++pair.candidates;
      if (auto link = Verify(a, candidate.keyframe_id, b, static_cast<int>(q), options)) {
        verified.push_back(*link);
        break;  // one link per keyframe of b: its best-voted verified place
      }
    }
  }
  pair.verified = static_cast<int>(verified.size());
  KeepAgreeing(a.record(), b.record(), options, verified, &pair);
  return pair;
}

}  // namespace stillmap
