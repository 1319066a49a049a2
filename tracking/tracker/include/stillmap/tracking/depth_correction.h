// Depth self-calibration: a smooth multiplicative error of the depth sensor over the image,
// estimated from the sequence itself.
//
// Structured-light sensors (Kinect, Xtion) read depth with an error that varies smoothly over the
// image and that no global scale removes (Teichman et al., "Unsupervised intrinsic calibration of
// depth sensors via SLAM", RSS 2013; Herrera et al., PAMI 2012). Modelled here as
//   z_true = z (1 + delta(x, y)),  delta = p1 x + p2 y + p3 x^2 + p4 y^2 + p5 x y,
// with (x, y) the undistorted normalized coordinates of the pixel. No constant term: a global
// depth scale trades against the translation and is left to the sensor's calibration.
//
// A static point seen with depth in two keyframes i and j gives, with j_from_i their relative
// pose and r_i = (x_i, y_i, 1), one equation that is exactly linear in p:
//   z_j (1 + delta_j) = [j_from_i (r_i z_i (1 + delta_i))]_z
//   (z_j phi_j - a z_i phi_i) . p = a z_i + t_z - z_j,   a = [R r_i]_z, t_z = [t]_z.
// The fit is least squares over such pairs, trimmed of outliers (3 x the residuals' MAD, three
// rounds), and taken only when it shrinks the pairs' disagreement. The poses come from the tracker,
// which uses the correction found so far, so refits during the run converge as an iteration.
#pragma once

#include <Eigen/Geometry>
#include <array>
#include <cmath>
#include <cstddef>
#include <opencv2/core.hpp>
#include <vector>

#include "stillmap/io/camera.h"

namespace stillmap {

struct DepthCorrection {
  std::array<double, 5>
      coefficients{};  // p1 .. p5 of delta = p1 x + p2 y + p3 x^2 + p4 y^2 + p5 xy

  // The model's basis at normalized (x, y): delta = p . Basis(x, y).
  static Eigen::Matrix<double, 5, 1> Basis(double x, double y) {
    Eigen::Matrix<double, 5, 1> phi;
    phi << x, y, x * x, y * y, x * y;
    return phi;
  }
  double Delta(double x, double y) const {
    const auto& p = coefficients;
    return p[0] * x + p[1] * y + p[2] * x * x + p[3] * y * y + p[4] * x * y;
  }
  // No more than max_delta in magnitude at any of `points` (normalized; the image's outline).
  bool WithinBounds(const std::vector<Eigen::Vector2d>& points, double max_delta) const {
    for (const Eigen::Vector2d& point : points) {
      if (!(std::abs(Delta(point.x(), point.y())) <= max_delta)) return false;
    }
    return true;
  }
  // The factor a raw depth at normalized (x, y) is multiplied by.
  double Factor(double x, double y) const { return 1.0 + Delta(x, y); }
  bool IsIdentity() const;
  // Per-pixel factors (CV_32FC1, camera size), undistorting each pixel's ray.
  cv::Mat FactorImage(const Camera& camera) const;
};

// Per-pixel factors of changing corrections for one camera: the undistorted rays are computed
// once (undistorting 640 x 480 pixels takes about 15 ms; the factors then take well under 1 ms).
class DepthFactorImages {
 public:
  explicit DepthFactorImages(const Camera& camera);
  // The factors of `correction` (CV_32FC1), recomputed only when the coefficients changed.
  const cv::Mat& For(const DepthCorrection& correction);

 private:
  Camera camera_;
  std::vector<Eigen::Vector2f> rays_;  // PixelRays(camera_)
  cv::Mat factors_;
  std::array<double, 5> coefficients_{};
};

// A static point seen with depth in keyframes i and j (raw depths).
struct DepthPair {
  Eigen::Vector2d normalized_i = Eigen::Vector2d::Zero();
  Eigen::Vector2d normalized_j = Eigen::Vector2d::Zero();
  double depth_i = 0.0;
  double depth_j = 0.0;
  Eigen::Isometry3d j_from_i = Eigen::Isometry3d::Identity();
};

struct DepthCorrectionFitOptions {
  size_t min_pairs = 2000;  // fewer: no fit
  double max_residual_m = 0.15;
  double max_delta = 0.15;
  double coefficient_sigma = 0.1;  // prior on each coefficient (keeps weak directions at zero)
  double residual_sigma_m = 0.03;
  // A fit must shrink the robust spread (1.4826 x MAD) of all the pairs' disagreements by at
  // least this share; else what it would remove is mostly pose error, and the poses drift.
  double min_spread_reduction = 0.1;
  // ... and by at least this much [m]: where the pairs already agree to a few millimetres there
  // is no sensor error to find, and a fit would bend depth to the pose errors.
  double min_spread_reduction_m = 0.002;
  // Joint estimation in the local bundle adjustment (tracking.depth_calibration_in_bundle_
  // adjustment). It starts once this many keyframes exist: with fewer, the baseline is short and
  // the correction trades with the poses.
  int joint_min_keyframes = 8;
  // Taken only when p' I p (its significance against "no error", chi-square with 5 dof without
  // one) reaches this: above what sensors without error give, below what real ones do.
  double joint_min_significance = 200.0;
  // ... and when its standard deviation along the least-seen direction is at most this: a camera
  // that barely moves sees every point from one place, where a depth error looks like a moved
  // point.
  double joint_max_weakest_sd = 0.05;

  // Every field under its configuration key (io/option_fields.h).
  template <typename Self, typename Visitor>
  static void VisitFields(Self& self, Visitor& visit) {
    visit("min_pairs", self.min_pairs, "landmark depth pairs a fit needs at least");
    visit("max_residual_m", self.max_residual_m,
          "pairs disagreeing by more are not the same static point [m]");
    visit("max_delta", self.max_delta,
          "a depth correction beyond this share anywhere in the image is refused");
    visit("coefficient_sigma", self.coefficient_sigma, "prior on each correction coefficient");
    visit("residual_sigma_m", self.residual_sigma_m,
          "depth disagreement of a pair, for the prior's weight [m]");
    visit("min_spread_reduction", self.min_spread_reduction,
          "a fit must shrink the pairs' robust spread by this share at least");
    visit("min_spread_reduction_m", self.min_spread_reduction_m,
          "... and by this much at least [m]");
    visit("joint_min_keyframes", self.joint_min_keyframes,
          "joint estimation in the bundle adjustment starts with this many keyframes");
    visit("joint_min_significance", self.joint_min_significance,
          "a joint estimate is taken when p' I p reaches this (chi-square, 5 dof)");
    visit("joint_max_weakest_sd", self.joint_max_weakest_sd,
          "... and its standard deviation in the least-seen direction is at most this");
  }
};

struct DepthCorrectionFit {
  bool ok = false;
  DepthCorrection correction;
  size_t pairs = 0;              // offered
  size_t pairs_used = 0;         // after trimming
  double spread_before_m = 0.0;  // 1.4826 x MAD of the disagreements, without and with the
  double spread_after_m = 0.0;   // correction
};

// Least-squares fit of the correction to `pairs`; image_corners (normalized coordinates of the
// image's corners) bound delta. Not ok (and no correction) with too few pairs or a fit that
// leaves the plausible range.
DepthCorrectionFit FitDepthCorrection(const std::vector<DepthPair>& pairs,
                                      const std::vector<Eigen::Vector2d>& image_corners,
                                      const DepthCorrectionFitOptions& options);

}  // namespace stillmap
