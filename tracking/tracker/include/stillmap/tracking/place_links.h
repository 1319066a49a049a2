// Links between the keyframes of two maps that do not know where they lie in each other (the
// sessions of a merge, the segments of a build after a loss): a keyframe verified against
// another's features with depth, and the largest set of links that agree on where one map lies in
// the other (the pairwise consistency check of Kimera-RPGO, Mangelson et al.'s PCM, simplified to
// agreement with a centre).
#pragma once

#include <Eigen/Geometry>
#include <opencv2/core.hpp>
#include <optional>
#include <vector>

#include "stillmap/io/session_record.h"

namespace stillmap {

struct PlaceLinkOptions {
  // Verification: ORB matches (best within max_descriptor_distance of 256 bits and below
  // match_ratio of the second best), PnP-RANSAC on the candidate's points with depth, then the
  // RGB-D refinement: at least min_inliers inliers.
  int max_descriptor_distance = 64;
  double match_ratio = 0.8;
  int min_inliers = 60;
  // Agreement: two links agree when the transforms they imply place the linked keyframe within
  // agreement_m of each other and differ by agreement_deg at most; min_links agreeing links join.
  int min_links = 3;
  double agreement_m = 0.15;
  double agreement_deg = 5.0;
};

// A keyframe as verification needs it: its features, their descriptors (CV_8U rows of 32 bytes)
// and those of its features with depth.
class LinkKeyframe {
 public:
  explicit LinkKeyframe(std::vector<SessionFeature> features);
  const std::vector<SessionFeature>& features() const { return features_; }
  const cv::Mat& descriptors() const { return descriptors_; }
  const std::vector<int>& with_depth() const { return with_depth_; }
  const cv::Mat& depth_descriptors() const { return depth_descriptors_; }
  size_t MemoryBytes() const;

 private:
  std::vector<SessionFeature> features_;
  cv::Mat descriptors_;
  std::vector<int> with_depth_;
  cv::Mat depth_descriptors_;
};

struct VerifiedLink {
  Eigen::Isometry3d c_from_q = Eigen::Isometry3d::Identity();  // camera q in camera c's frame
  int inliers = 0;
};

// Keyframe q seen from keyframe c: ORB matches from q's features to c's features with depth,
// PnP-RANSAC, then the RGB-D refinement with q's depth (q_fx: q's focal length [px], which scales
// its features' pixel noise). Nothing when fewer than min_inliers survive.
std::optional<VerifiedLink> VerifyLink(const LinkKeyframe& c, const LinkKeyframe& q, double q_fx,
                                       const PlaceLinkOptions& options);

// Links, each implying a_from_b (map b's frame in map a's) and having linked the keyframe of b at
// `b_positions` (in b's frame): the links that agree with the one most others agree with (ties:
// the earlier), in their order, and that one's index. Empty for no links.
struct LinkAgreement {
  std::vector<size_t> agreeing;
  size_t centre = 0;
};
LinkAgreement AgreeingLinks(const std::vector<Eigen::Isometry3d>& implied,
                            const std::vector<Eigen::Vector3d>& b_positions,
                            const PlaceLinkOptions& options);

}  // namespace stillmap
