// Camera pose from 3-D points and their observations (PnP with RANSAC).
#pragma once

#include <Eigen/Geometry>
#include <vector>

namespace stillmap {

struct PnpOptions {
  // RANSAC inlier threshold in normalized coordinates (about 3.2 px at fx = 525): loose, so that
  // sampling ends early (AP3P minimal sets); the final least-squares fit uses the tighter
  // refine_reprojection_error (about 1.6 px).
  double max_reprojection_error = 0.006;
  double refine_reprojection_error = 0.003;
  int iterations = 200;
  double confidence = 0.999;
  int min_inliers = 12;

  // Every field under its configuration key (io/option_fields.h).
  template <typename Self, typename Visitor>
  static void VisitFields(Self& self, Visitor& visit) {
    visit("max_reprojection_error", self.max_reprojection_error,
          "RANSAC inlier threshold [normalized image units; 0.006 = 3.2 px at fx 525]");
    visit("refine_reprojection_error", self.refine_reprojection_error,
          "inlier threshold of the final least-squares fit [normalized image units]");
    visit("iterations", self.iterations, "RANSAC iterations at most");
    visit("confidence", self.confidence, "RANSAC confidence");
    visit("min_inliers", self.min_inliers, "fewer inliers: the pose is not trusted");
  }
};

enum class PoseStatus { kOk, kTooFewPoints, kTooFewInliers };

// Outcome of a pose estimate, with the figures that explain it.
struct PoseResult {
  PoseStatus status = PoseStatus::kTooFewPoints;
  Eigen::Isometry3d camera_from_world = Eigen::Isometry3d::Identity();
  std::vector<int> inliers;        // indices into the input correspondences
  double reprojection_rmse = 0.0;  // over the inliers, normalized coordinates
  bool ok() const { return status == PoseStatus::kOk; }
};

// Estimates camera_from_world from world points and their undistorted normalized observations
// (x/z, y/z): RANSAC over minimal sets (OpenCV's solvePnPRansac, EPnP), then an iterative
// refinement on the inliers.
PoseResult EstimatePosePnp(const std::vector<Eigen::Vector3d>& points_in_world,
                           const std::vector<Eigen::Vector2d>& observations,
                           const PnpOptions& options = {});

}  // namespace stillmap
