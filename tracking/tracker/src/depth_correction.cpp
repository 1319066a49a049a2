#include "stillmap/tracking/depth_correction.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdint>

#include "median.h"

namespace stillmap {
namespace {

using Row = Eigen::Matrix<double, 5, 1>;

Row Basis(const Eigen::Vector2d& n) { return DepthCorrection::Basis(n.x(), n.y()); }

void Factors(const DepthCorrection& correction, const std::vector<Eigen::Vector2f>& rays,
             const Camera& camera, cv::Mat* factors) {
  factors->create(camera.height, camera.width, CV_32FC1);
  auto* out = factors->ptr<float>();
  for (size_t i = 0; i < rays.size(); ++i) {
    out[i] = static_cast<float>(correction.Factor(rays[i].x(), rays[i].y()));
  }
}

}  // namespace

bool DepthCorrection::IsIdentity() const {
  return std::all_of(coefficients.begin(), coefficients.end(), [](double c) { return c == 0.0; });
}

cv::Mat DepthCorrection::FactorImage(const Camera& camera) const {
  if (IsIdentity()) return cv::Mat(camera.height, camera.width, CV_32FC1, cv::Scalar(1.0f));
  cv::Mat factors;
  Factors(*this, PixelRays(camera), camera, &factors);
  return factors;
}

DepthFactorImages::DepthFactorImages(const Camera& camera)
    : camera_(camera),
      rays_(PixelRays(camera)),
      factors_(camera.height, camera.width, CV_32FC1, cv::Scalar(1.0f)) {}

const cv::Mat& DepthFactorImages::For(const DepthCorrection& correction) {
  if (correction.coefficients != coefficients_) {
    Factors(correction, rays_, camera_, &factors_);
    coefficients_ = correction.coefficients;
  }
  return factors_;
}

DepthCorrectionFit FitDepthCorrection(const std::vector<DepthPair>& pairs,
                                      const std::vector<Eigen::Vector2d>& image_corners,
                                      const DepthCorrectionFitOptions& options) {
  DepthCorrectionFit fit;
  fit.pairs = pairs.size();
  std::vector<Row> rows;
  std::vector<double> rhs;
  rows.reserve(pairs.size());
  rhs.reserve(pairs.size());
  for (const DepthPair& pair : pairs) {
    const Eigen::Vector3d ray_i(pair.normalized_i.x(), pair.normalized_i.y(), 1.0);
    const double a = (pair.j_from_i.linear() * ray_i).z();
    const double t_z = pair.j_from_i.translation().z();
    const double disagreement = a * pair.depth_i + t_z - pair.depth_j;
    if (!(std::abs(disagreement) <= options.max_residual_m)) continue;
    rows.push_back(pair.depth_j * Basis(pair.normalized_j) -
                   a * pair.depth_i * Basis(pair.normalized_i));
    rhs.push_back(disagreement);
  }
  if (rows.size() < options.min_pairs) return fit;

  const double prior = std::pow(options.residual_sigma_m / options.coefficient_sigma, 2);
  Row p = Row::Zero();
  std::vector<std::uint8_t> used(rows.size(), 1);
  for (int round = 0; round < 3; ++round) {
    Eigen::Matrix<double, 5, 5> normal = prior * Eigen::Matrix<double, 5, 5>::Identity();
    Row right = Row::Zero();
    for (size_t k = 0; k < rows.size(); ++k) {
      if (used[k] == 0) continue;
      normal.noalias() += rows[k] * rows[k].transpose();
      right += rows[k] * rhs[k];
    }
    p = normal.ldlt().solve(right);
    std::vector<double> magnitudes;
    magnitudes.reserve(rows.size());
    for (size_t k = 0; k < rows.size(); ++k)
      magnitudes.push_back(std::abs(rows[k].dot(p) - rhs[k]));
    const double limit = 3.0 * 1.4826 * Median(magnitudes);
    for (size_t k = 0; k < rows.size(); ++k) used[k] = magnitudes[k] <= limit ? 1 : 0;
  }

  // The pairs' disagreement without and with the correction, as a robust spread over all of them
  // (the trimmed set would favour the fit that chose it).
  std::vector<double> raw, corrected;
  raw.reserve(rows.size());
  corrected.reserve(rows.size());
  for (size_t k = 0; k < rows.size(); ++k) {
    fit.pairs_used += used[k] != 0 ? 1 : 0;
    raw.push_back(std::abs(rhs[k]));
    corrected.push_back(std::abs(rows[k].dot(p) - rhs[k]));
  }
  if (fit.pairs_used < options.min_pairs) return fit;
  fit.spread_before_m = 1.4826 * Median(std::move(raw));
  fit.spread_after_m = 1.4826 * Median(std::move(corrected));
  if (!(fit.spread_after_m <= (1.0 - options.min_spread_reduction) * fit.spread_before_m) ||
      !(fit.spread_before_m - fit.spread_after_m >= options.min_spread_reduction_m)) {
    return fit;
  }
  DepthCorrection correction;
  for (int i = 0; i < 5; ++i) correction.coefficients[static_cast<size_t>(i)] = p[i];
  if (!correction.WithinBounds(image_corners, options.max_delta)) return fit;
  fit.correction = correction;
  fit.ok = true;
  return fit;
}

}  // namespace stillmap
