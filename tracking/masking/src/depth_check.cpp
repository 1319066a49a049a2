#include "stillmap/tracking/depth_check.h"

#include <cmath>
#include <opencv2/calib3d.hpp>

namespace stillmap {

std::vector<DepthCheck> CheckDepth(const std::vector<Eigen::Vector3d>& points_in_reference,
                                   const Eigen::Isometry3d& current_from_reference,
                                   const cv::Mat& current_depth_m, const Camera& camera,
                                   const DepthCheckOptions& options) {
  CV_Assert(current_depth_m.type() == CV_32FC1);
  std::vector<DepthCheck> checks(points_in_reference.size());
  std::vector<cv::Point3d> in_current;
  std::vector<size_t> index;
  // The reference camera's centre, in the current camera frame.
  const Eigen::Vector3d reference_centre = current_from_reference.translation();
  const double cos_limit = std::cos(options.max_parallax_deg * M_PI / 180.0);
  for (size_t i = 0; i < points_in_reference.size(); ++i) {
    const Eigen::Vector3d q = current_from_reference * points_in_reference[i];
    DepthCheck& check = checks[i];
    check.projected_depth_m = q.z();
    if (!(q.z() > 0.05)) continue;
    // Parallax: the angle at the point between the rays to the two camera centres.
    const Eigen::Vector3d to_current = -q, to_reference = reference_centre - q;
    const double cos_angle = to_current.normalized().dot(to_reference.normalized());
    check.parallax_deg = std::acos(std::clamp(cos_angle, -1.0, 1.0)) * 180.0 / M_PI;
    if (cos_angle < cos_limit) continue;
    in_current.emplace_back(q.x(), q.y(), q.z());
    index.push_back(i);
  }
  if (in_current.empty()) return checks;
  const cv::Matx33d k(camera.fx, 0, camera.cx, 0, camera.fy, camera.cy, 0, 0, 1);
  const std::vector<double> distortion = camera.Coefficients();
  std::vector<cv::Point2d> pixels;
  cv::projectPoints(in_current, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), k, distortion, pixels);
  for (size_t j = 0; j < index.size(); ++j) {
    DepthCheck& check = checks[index[j]];
    check.pixel = cv::Point2f(static_cast<float>(pixels[j].x), static_cast<float>(pixels[j].y));
    // Bounds in floating point first: a conversion of a wild projection (+-1e30) would wrap.
    const double pu = std::floor(pixels[j].x + 0.5), pv = std::floor(pixels[j].y + 0.5);
    if (!(pu >= 0.0 && pv >= 0.0 && pu < current_depth_m.cols && pv < current_depth_m.rows)) {
      continue;
    }
    const int u = static_cast<int>(pu), v = static_cast<int>(pv);
    const float measured = current_depth_m.at<float>(v, u);
    check.measured_depth_m = measured;
    if (!(measured > 0.0f)) continue;
    check.verdict = check.projected_depth_m - measured > options.max_depth_difference_m
                        ? DepthVerdict::kDynamic
                        : DepthVerdict::kStatic;
  }
  return checks;
}

}  // namespace stillmap
