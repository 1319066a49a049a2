// The session record of a build whose poses were given and used as they are (poses.use=map):
// no tracker made keyframes, so the fused frames that moved a tracker's keyframe apart
// (kSessionDistanceM, kSessionAngleDeg) are kept with their ORB features, masked depth and
// colour, for stillmap merge to join the session like any other.
#pragma once

#include <vector>

#include "stillmap/io/camera.h"
#include "stillmap/io/sequence.h"
#include "stillmap/io/session_keyframes.h"
#include "stillmap/tracking/features.h"

namespace stillmap {

class GivenSessionKeeper {
 public:
  // `max_depth_m`: the back-projection's range, which the kept depth PNGs' step covers.
  GivenSessionKeeper(const Camera& camera, const FeatureOptions& features, double max_depth_m);
  // Keeps a fused frame when it lies far enough from the last kept one.
  void Offer(const Frame& frame, const cv::Mat& gray, const cv::Mat& mask,
             const Eigen::Isometry3d& world_from_camera);
  SessionKeyframeList Take() { return std::move(kept_); }
  double depth_unit_m() const { return depth_unit_m_; }

 private:
  Camera camera_;
  FeatureOptions features_;
  double depth_unit_m_;
  SessionKeyframeList kept_;  // parked in a temporary file
  Eigen::Isometry3d last_kept_ = Eigen::Isometry3d::Identity();
};

}  // namespace stillmap
