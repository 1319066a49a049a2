#include "stillmap/tracking/place_links.h"

#include <cmath>
#include <cstring>
#include <opencv2/features2d.hpp>

#include "stillmap/tracking/pose_estimation.h"
#include "stillmap/tracking/pose_refinement.h"

namespace stillmap {

LinkKeyframe::LinkKeyframe(std::vector<SessionFeature> features)
    : features_(std::move(features)), descriptors_(static_cast<int>(features_.size()), 32, CV_8U) {
  for (size_t i = 0; i < features_.size(); ++i) {
    std::memcpy(descriptors_.ptr(static_cast<int>(i)), features_[i].descriptor.data(), 32);
    if (features_[i].depth_m > 0.0f) with_depth_.push_back(static_cast<int>(i));
  }
  // The features with depth, which verification matches against, gathered once.
  depth_descriptors_.create(static_cast<int>(with_depth_.size()), 32, CV_8U);
  for (size_t i = 0; i < with_depth_.size(); ++i) {
    descriptors_.row(with_depth_[i]).copyTo(depth_descriptors_.row(static_cast<int>(i)));
  }
}

size_t LinkKeyframe::MemoryBytes() const {
  return features_.capacity() * sizeof(SessionFeature) + descriptors_.total() +
         with_depth_.capacity() * sizeof(int) + depth_descriptors_.total();
}

std::optional<VerifiedLink> VerifyLink(const LinkKeyframe& c, const LinkKeyframe& q, double q_fx,
                                       const PlaceLinkOptions& options) {
  const std::vector<int>& with_depth = c.with_depth();
  if (with_depth.size() < static_cast<size_t>(options.min_inliers)) return std::nullopt;
  std::vector<std::vector<cv::DMatch>> knn;
  cv::BFMatcher(cv::NORM_HAMMING).knnMatch(q.descriptors(), c.depth_descriptors(), knn, 2);
  std::vector<Eigen::Vector3d> points;
  std::vector<Eigen::Vector2d> observations;
  std::vector<RgbdObservation> rgbd;
  for (const std::vector<cv::DMatch>& best : knn) {
    if (best.empty() || best[0].distance > static_cast<float>(options.max_descriptor_distance)) {
      continue;
    }
    if (best.size() > 1 && best[0].distance >= options.match_ratio * best[1].distance) continue;
    const SessionFeature& fc =
        c.features()[static_cast<size_t>(with_depth[static_cast<size_t>(best[0].trainIdx)])];
    const SessionFeature& fq = q.features()[static_cast<size_t>(best[0].queryIdx)];
    points.push_back(fc.depth_m * Eigen::Vector3d(fc.x, fc.y, 1.0));
    observations.emplace_back(fq.x, fq.y);
    RgbdObservation observation;
    observation.normalized = observations.back();
    observation.depth_m = fq.depth_m;
    observation.sigma_normalized = std::pow(1.2, fq.octave) / q_fx;
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
  return VerifiedLink{refined.camera_from_world.inverse(),
                      static_cast<int>(refined.inliers.size())};
}

LinkAgreement AgreeingLinks(const std::vector<Eigen::Isometry3d>& implied,
                            const std::vector<Eigen::Vector3d>& b_positions,
                            const PlaceLinkOptions& options) {
  LinkAgreement agreement;
  const double max_rad = options.agreement_deg * M_PI / 180.0;
  auto agree = [&](size_t i, size_t j) {
    const Eigen::Vector3d& at = b_positions[j];
    const Eigen::AngleAxisd turn((implied[i].inverse() * implied[j]).linear());
    return (implied[i] * at - implied[j] * at).norm() <= options.agreement_m &&
           std::abs(turn.angle()) <= max_rad;
  };
  size_t best_count = 0;
  for (size_t i = 0; i < implied.size(); ++i) {
    size_t count = 0;
    for (size_t j = 0; j < implied.size(); ++j) count += agree(i, j) ? 1 : 0;
    if (count > best_count) {  // ties: the earlier link, so that the result repeats
      agreement.centre = i;
      best_count = count;
    }
  }
  for (size_t j = 0; j < implied.size(); ++j) {
    if (agree(agreement.centre, j)) agreement.agreeing.push_back(j);
  }
  return agreement;
}

}  // namespace stillmap
