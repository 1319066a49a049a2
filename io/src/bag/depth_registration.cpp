#include "bag/depth_registration.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <opencv2/calib3d.hpp>
#include <queue>

#include "stillmap/io/error.h"

namespace stillmap {
namespace {

// The camera's distortion as OpenCV's rational model k1 k2 p1 p2 k3 k4 k5 k6 (plumb_bob's has
// k4..k6 zero); refuses what that cannot express.
std::array<double, 8> Rational(const RosCameraInfo& info, const std::string& where) {
  std::array<double, 8> d{};
  for (size_t i = 0; i < info.d.size(); ++i) {
    if (i < 8) {
      d[i] = info.d[i];
    } else if (info.d[i] != 0.0) {
      throw InputError(where + ": distortion " + Quoted(info.distortion_model) + " with " +
                       std::to_string(info.d.size()) +
                       " coefficients cannot be registered (k1 k2 p1 p2 k3 k4 k5 k6)");
    }
  }
  return d;
}

}  // namespace

Eigen::Isometry3d IsometryOf(const RosTransform& transform) {
  const auto& [x, y, z, w] = transform.rotation;
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = Eigen::Quaterniond(w, x, y, z).normalized().toRotationMatrix();
  pose.translation() =
      Eigen::Vector3d(transform.translation[0], transform.translation[1], transform.translation[2]);
  return pose;
}

DepthRegistration::DepthRegistration(const RosCameraInfo& depth, const RosCameraInfo& color,
                                     const Eigen::Isometry3d& color_from_depth,
                                     const std::string& where)
    : depth_width_(static_cast<int>(depth.width)),
      depth_height_(static_cast<int>(depth.height)),
      color_width_(static_cast<int>(color.width)),
      color_height_(static_cast<int>(color.height)),
      rotation_(color_from_depth.linear().cast<float>()),
      translation_(color_from_depth.translation().cast<float>()),
      fx_(static_cast<float>(color.k[0])),
      fy_(static_cast<float>(color.k[4])),
      cx_(static_cast<float>(color.k[2])),
      cy_(static_cast<float>(color.k[5])) {
  const std::array<double, 8> color_d = Rational(color, where);
  for (size_t i = 0; i < 8; ++i) distortion_[i] = static_cast<float>(color_d[i]);
  const std::array<double, 8> depth_d = Rational(depth, where);
  std::vector<cv::Point2f> corners;
  corners.reserve(static_cast<size_t>(depth_width_ + 1) * (depth_height_ + 1));
  for (int v = 0; v <= depth_height_; ++v) {
    for (int u = 0; u <= depth_width_; ++u) corners.emplace_back(u - 0.5f, v - 0.5f);
  }
  const cv::Matx33d k(depth.k.data());
  std::vector<cv::Point2f> rays;
  cv::undistortPoints(corners, rays, k, std::vector<double>(depth_d.begin(), depth_d.end()));
  corner_rays_ = cv::Mat(rays, true).reshape(2, depth_height_ + 1);
}

cv::Point2f DepthRegistration::Project(const Eigen::Vector3f& point) const {
  const float x = point.x() / point.z(), y = point.y() / point.z();
  const float r2 = x * x + y * y;
  const auto& [k1, k2, p1, p2, k3, k4, k5, k6] = distortion_;
  const float radial =
      (1.0f + r2 * (k1 + r2 * (k2 + r2 * k3))) / (1.0f + r2 * (k4 + r2 * (k5 + r2 * k6)));
  const float xd = x * radial + 2.0f * p1 * x * y + p2 * (r2 + 2.0f * x * x);
  const float yd = y * radial + p1 * (r2 + 2.0f * y * y) + 2.0f * p2 * x * y;
  return {fx_ * xd + cx_, fy_ * yd + cy_};
}

cv::Mat DepthRegistration::Register(const cv::Mat& depth_m, const std::string& where) const {
  if (depth_m.type() != CV_32FC1 || depth_m.cols != depth_width_ || depth_m.rows != depth_height_) {
    throw InputError(where + ": depth is " + std::to_string(depth_m.cols) + "x" +
                     std::to_string(depth_m.rows) + ", but its CameraInfo says " +
                     std::to_string(depth_width_) + "x" + std::to_string(depth_height_));
  }
  cv::Mat registered(color_height_, color_width_, CV_32FC1, cv::Scalar(0.0f));
  for (int v = 0; v < depth_height_; ++v) {
    const float* z_row = depth_m.ptr<float>(v);
    const cv::Vec2f* top = corner_rays_.ptr<cv::Vec2f>(v);
    const cv::Vec2f* bottom = corner_rays_.ptr<cv::Vec2f>(v + 1);
    for (int u = 0; u < depth_width_; ++u) {
      const float z = z_row[u];
      if (!(z > 0.0f)) continue;
      const Eigen::Vector3f a =
          rotation_ * Eigen::Vector3f(top[u][0] * z, top[u][1] * z, z) + translation_;
      const Eigen::Vector3f b =
          rotation_ * Eigen::Vector3f(bottom[u + 1][0] * z, bottom[u + 1][1] * z, z) + translation_;
      if (!(a.z() > 0.0f) || !(b.z() > 0.0f)) continue;
      const cv::Point2f pa = Project(a), pb = Project(b);
      // The colour pixels whose centres lie in the footprint (at least the nearest one).
      const int u0 = std::max(0, static_cast<int>(std::ceil(std::min(pa.x, pb.x) - 0.5f)));
      const int u1 =
          std::min(color_width_ - 1, static_cast<int>(std::floor(std::max(pa.x, pb.x) - 0.5f)));
      const int v0 = std::max(0, static_cast<int>(std::ceil(std::min(pa.y, pb.y) - 0.5f)));
      const int v1 =
          std::min(color_height_ - 1, static_cast<int>(std::floor(std::max(pa.y, pb.y) - 0.5f)));
      const float depth = 0.5f * (a.z() + b.z());
      for (int cv_row = v0; cv_row <= v1; ++cv_row) {
        float* out = registered.ptr<float>(cv_row);
        for (int cu = u0; cu <= u1; ++cu) {
          if (out[cu] == 0.0f || depth < out[cu]) out[cu] = depth;
        }
      }
    }
  }
  return registered;
}

std::optional<Eigen::Isometry3d> FindStaticTransform(const std::vector<RosTransform>& transforms,
                                                     const std::string& target,
                                                     const std::string& source) {
  // Breadth-first from `target` over the transforms as undirected edges: pose of each frame
  // reached, in `target`.
  std::map<std::string, Eigen::Isometry3d> pose_in_target = {
      {target, Eigen::Isometry3d::Identity()}};
  std::queue<std::string> frontier;
  frontier.push(target);
  while (!frontier.empty()) {
    const std::string frame = frontier.front();
    frontier.pop();
    const Eigen::Isometry3d frame_pose = pose_in_target.at(frame);
    for (const RosTransform& transform : transforms) {
      const bool down = transform.parent == frame, up = transform.child == frame;
      if (!down && !up) continue;
      const std::string& next = down ? transform.child : transform.parent;
      if (pose_in_target.count(next) > 0) continue;
      const Eigen::Isometry3d parent_from_child = IsometryOf(transform);
      pose_in_target[next] = frame_pose * (down ? parent_from_child : parent_from_child.inverse());
      frontier.push(next);
    }
  }
  const auto found = pose_in_target.find(source);
  if (found == pose_in_target.end()) return std::nullopt;
  return found->second;
}

}  // namespace stillmap
