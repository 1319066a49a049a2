#include "merge_links.h"

#include <opencv2/features2d.hpp>

#include "stillmap/tracking/pose_estimation.h"
#include "stillmap/tracking/pose_refinement.h"

namespace stillmap {
namespace {

// The place index's hash masks come from this seed, so that a merge repeats exactly.
constexpr std::uint64_t kPlaceSeed = 0x5e55105;

cv::Mat Descriptors(const SessionKeyframe& keyframe) {
  cv::Mat out(static_cast<int>(keyframe.features.size()), 32, CV_8U);
  for (size_t i = 0; i < keyframe.features.size(); ++i) {
    std::memcpy(out.ptr(static_cast<int>(i)), keyframe.features[i].descriptor.data(), 32);
  }
  return out;
}

// Keyframe q (of b) in the frame of keyframe c (of a): ORB matches from q's features to c's
// features with depth, PnP-RANSAC, then the RGB-D refinement with q's depth. Nothing when fewer
// than min_inliers survive.
std::optional<SessionLink> Verify(const SessionPlaces& a, int c, const SessionPlaces& b, int q,
                                  const MergeOptions& options) {
  const SessionKeyframe& kc = a.record().keyframes[static_cast<size_t>(c)];
  const SessionKeyframe& kq = b.record().keyframes[static_cast<size_t>(q)];
  const std::vector<int>& with_depth = a.with_depth(static_cast<size_t>(c));
  if (with_depth.size() < static_cast<size_t>(options.min_inliers)) return std::nullopt;
  std::vector<std::vector<cv::DMatch>> knn;
  cv::BFMatcher(cv::NORM_HAMMING)
      .knnMatch(b.descriptors(static_cast<size_t>(q)), a.depth_descriptors(static_cast<size_t>(c)),
                knn, 2);
  std::vector<Eigen::Vector3d> points;
  std::vector<Eigen::Vector2d> observations;
  std::vector<RgbdObservation> rgbd;
  const double fx = b.record().camera.fx;  // q's camera observes
  for (const std::vector<cv::DMatch>& best : knn) {
    if (best.empty() || best[0].distance > static_cast<float>(options.max_descriptor_distance)) {
      continue;
    }
    if (best.size() > 1 && best[0].distance >= options.match_ratio * best[1].distance) continue;
    const SessionFeature& fc =
        kc.features[static_cast<size_t>(with_depth[static_cast<size_t>(best[0].trainIdx)])];
    const SessionFeature& fq = kq.features[static_cast<size_t>(best[0].queryIdx)];
    points.push_back(fc.depth_m * Eigen::Vector3d(fc.x, fc.y, 1.0));
    observations.emplace_back(fq.x, fq.y);
    RgbdObservation observation;
    observation.normalized = observations.back();
    observation.depth_m = fq.depth_m;
    observation.sigma_normalized = std::pow(1.2, fq.octave) / fx;
    observation.sigma_inverse_depth = 0.0025;  // tracking.sigma_inverse_depth
    rgbd.push_back(observation);
  }
  if (points.size() < static_cast<size_t>(options.min_inliers)) return std::nullopt;
  const PoseResult pnp = EstimatePosePnp(points, observations);
  if (!pnp.ok() || pnp.inliers.size() < static_cast<size_t>(options.min_inliers)) {
    return std::nullopt;
  }
  const PoseResult refined = RefinePose(pnp.camera_from_world, points, rgbd);
  if (!refined.ok() || refined.inliers.size() < static_cast<size_t>(options.min_inliers)) {
    return std::nullopt;
  }
  return SessionLink{c, q, refined.camera_from_world.inverse(),
                     static_cast<int>(refined.inliers.size())};
}

// Where the link puts session b's frame in session a's.
Eigen::Isometry3d Implied(const SessionLink& link, const SessionRecord& a, const SessionRecord& b) {
  return a.keyframes[static_cast<size_t>(link.keyframe_a)].map_from_camera * link.a_from_b *
         b.keyframes[static_cast<size_t>(link.keyframe_b)].map_from_camera.inverse();
}

// The largest set of links that agree with one of them (Kimera-RPGO's pairwise consistency,
// simplified to agreement with a centre): two implied transforms agree when they place the
// linked keyframe of b within agreement_m of each other and differ by agreement_deg at most.
void KeepAgreeing(const SessionRecord& a, const SessionRecord& b, const MergeOptions& options,
                  std::vector<SessionLink> links, PairLinks* pair) {
  std::vector<Eigen::Isometry3d> implied;
  implied.reserve(links.size());
  for (const SessionLink& link : links) implied.push_back(Implied(link, a, b));
  const double max_rad = options.agreement_deg * M_PI / 180.0;
  auto agree = [&](size_t i, size_t j) {
    const Eigen::Vector3d at =
        b.keyframes[static_cast<size_t>(links[j].keyframe_b)].map_from_camera.translation();
    const Eigen::AngleAxisd turn((implied[i].inverse() * implied[j]).linear());
    return (implied[i] * at - implied[j] * at).norm() <= options.agreement_m &&
           std::abs(turn.angle()) <= max_rad;
  };
  size_t best = 0, best_count = 0;
  for (size_t i = 0; i < links.size(); ++i) {
    size_t count = 0;
    for (size_t j = 0; j < links.size(); ++j) count += agree(i, j) ? 1 : 0;
    if (count > best_count) {  // ties: the earlier link, so that the result repeats
      best = i;
      best_count = count;
    }
  }
  if (links.empty()) return;
  for (size_t j = 0; j < links.size(); ++j) {
    if (agree(best, j)) pair->agreeing.push_back(links[j]);
  }
  pair->a_map_from_b_map = implied[best];
  pair->joined = pair->agreeing.size() >= static_cast<size_t>(options.min_links);
}

}  // namespace

SessionPlaces::SessionPlaces(const SessionRecord& record, const PlaceIndexOptions& index_options)
    : record_(record), index_(index_options, kPlaceSeed) {
  for (size_t k = 0; k < record.keyframes.size(); ++k) {
    descriptors_.push_back(Descriptors(record.keyframes[k]));
    index_.Add(static_cast<int>(k), descriptors_.back());
    // The features with depth, which verification matches against, once per keyframe.
    std::vector<int> with_depth;
    for (size_t i = 0; i < record.keyframes[k].features.size(); ++i) {
      if (record.keyframes[k].features[i].depth_m > 0.0f) with_depth.push_back(static_cast<int>(i));
    }
    cv::Mat depth_descriptors(static_cast<int>(with_depth.size()), 32, CV_8U);
    for (size_t i = 0; i < with_depth.size(); ++i) {
      descriptors_.back().row(with_depth[i]).copyTo(depth_descriptors.row(static_cast<int>(i)));
    }
    with_depth_.push_back(std::move(with_depth));
    depth_descriptors_.push_back(depth_descriptors);
  }
}

PairLinks FindLinks(const SessionPlaces& a, const SessionPlaces& b, int index_a, int index_b,
                    const MergeOptions& options) {
  PairLinks pair;
  pair.session_a = index_a;
  pair.session_b = index_b;
  std::vector<SessionLink> verified;
  for (size_t q = 0; q < b.record().keyframes.size(); ++q) {
    const std::vector<PlaceCandidate> candidates = a.index().Query(
        b.descriptors(q), static_cast<size_t>(options.place_candidates), [](int) { return false; });
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
  KeepAgreeing(a.record(), b.record(), options, std::move(verified), &pair);
  return pair;
}

}  // namespace stillmap
