#include "given_session.h"

#include <opencv2/imgcodecs.hpp>

#include "keyframe_fuser.h"
#include "stillmap/io/trajectory.h"

namespace stillmap {
namespace {

// About a tracked build's keyframe spacing (teddy, bonn_crowd_a: 20-24 fused keyframes).
constexpr double kSessionDistanceM = 0.1;
constexpr double kSessionAngleDeg = 10.0;

}  // namespace

GivenSessionKeeper::GivenSessionKeeper(const Camera& camera, const FeatureOptions& features,
                                       double max_depth_m)
    : camera_(camera), features_(features), depth_unit_m_(max_depth_m / 60000.0) {}

void GivenSessionKeeper::Offer(const Frame& frame, const cv::Mat& gray, const cv::Mat& mask,
                               const Eigen::Isometry3d& world_from_camera) {
  if (!kept_.empty() &&
      !MovedOrTurned(last_kept_, world_from_camera, kSessionDistanceM, kSessionAngleDeg)) {
    return;
  }
  SessionKeyframeBlocks blocks;
  blocks.keyframe.id = static_cast<int>(kept_.size());
  blocks.keyframe.time = frame.time;
  blocks.keyframe.map_from_camera = world_from_camera;
  blocks.keyframe.features =
      SessionFeatures(ExtractFeatures(gray, frame.depth_m, camera_, mask, features_));
  cv::Mat depth;
  frame.depth_m.convertTo(depth, CV_16U, 1.0 / depth_unit_m_);  // saturates beyond the range
  if (!mask.empty()) depth.setTo(0, mask);
  cv::imencode(".png", depth, blocks.depth_png, {cv::IMWRITE_PNG_COMPRESSION, 1});
  cv::imencode(".jpg", frame.color, blocks.color_jpeg, {cv::IMWRITE_JPEG_QUALITY, 95});
  kept_.Add(blocks);
  last_kept_ = world_from_camera;
}

}  // namespace stillmap
