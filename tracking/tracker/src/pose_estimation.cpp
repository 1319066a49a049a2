#include "stillmap/tracking/pose_estimation.h"

#include <cmath>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>

namespace stillmap {

PoseResult EstimatePosePnp(const std::vector<Eigen::Vector3d>& points_in_world,
                           const std::vector<Eigen::Vector2d>& observations,
                           const PnpOptions& options) {
  PoseResult result;
  if (points_in_world.size() < 6 || points_in_world.size() != observations.size()) return result;
  std::vector<cv::Point3d> object;
  std::vector<cv::Point2d> image;
  for (size_t i = 0; i < points_in_world.size(); ++i) {
    object.emplace_back(points_in_world[i].x(), points_in_world[i].y(), points_in_world[i].z());
    image.emplace_back(observations[i].x(), observations[i].y());
  }
  // Observations are normalized: the camera matrix is the identity.
  const cv::Matx33d identity = cv::Matx33d::eye();
  cv::Mat rvec, tvec;
  std::vector<int> inliers;
  const bool found =
      cv::solvePnPRansac(object, image, identity, cv::noArray(), rvec, tvec, false,
                         options.iterations, static_cast<float>(options.max_reprojection_error),
                         options.confidence, inliers, cv::SOLVEPNP_AP3P);
  if (!found || static_cast<int>(inliers.size()) < options.min_inliers) {
    result.status = PoseStatus::kTooFewInliers;
    result.inliers = inliers;
    return result;
  }
  // The RANSAC threshold is loose so that sampling ends early; the least-squares refinement
  // (Levenberg-Marquardt on the reprojection error) uses only the correspondences within the
  // tighter refinement threshold of the RANSAC pose, when enough are.
  {
    cv::Mat rotation;
    cv::Rodrigues(rvec, rotation);
    const cv::Matx33d r(rotation);
    const cv::Vec3d t(tvec);
    std::vector<int> tight;
    const double limit = options.refine_reprojection_error * options.refine_reprojection_error;
    for (int i : inliers) {
      const cv::Vec3d q =
          r * cv::Vec3d(object[static_cast<size_t>(i)].x, object[static_cast<size_t>(i)].y,
                        object[static_cast<size_t>(i)].z) +
          t;
      if (q[2] <= 0.0) continue;
      const double du = q[0] / q[2] - image[static_cast<size_t>(i)].x;
      const double dv = q[1] / q[2] - image[static_cast<size_t>(i)].y;
      if (du * du + dv * dv < limit) tight.push_back(i);
    }
    if (static_cast<int>(tight.size()) >= options.min_inliers) inliers = std::move(tight);
  }
  std::vector<cv::Point3d> inlier_object;
  std::vector<cv::Point2d> inlier_image;
  for (int i : inliers) {
    inlier_object.push_back(object[static_cast<size_t>(i)]);
    inlier_image.push_back(image[static_cast<size_t>(i)]);
  }
  cv::solvePnPRefineLM(inlier_object, inlier_image, identity, cv::noArray(), rvec, tvec);
  cv::Mat rotation;
  cv::Rodrigues(rvec, rotation);
  Eigen::Matrix3d r;
  cv::cv2eigen(rotation, r);
  result.camera_from_world.linear() = r;
  result.camera_from_world.translation() =
      Eigen::Vector3d(tvec.at<double>(0), tvec.at<double>(1), tvec.at<double>(2));
  double sum = 0.0;
  for (int i : inliers) {
    const Eigen::Vector3d q = result.camera_from_world * points_in_world[static_cast<size_t>(i)];
    sum += (q.head<2>() / q.z() - observations[static_cast<size_t>(i)]).squaredNorm();
  }
  result.reprojection_rmse = std::sqrt(sum / static_cast<double>(inliers.size()));
  result.inliers = std::move(inliers);
  result.status = PoseStatus::kOk;
  return result;
}

}  // namespace stillmap
