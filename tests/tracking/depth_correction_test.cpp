// Depth self-calibration: the fit recovers a known depth error from exact point pairs with sensor
// noise, refuses to invent one where there is none, and the factor image agrees with the model.
#include "stillmap/tracking/depth_correction.h"

#include <gtest/gtest.h>

#include <random>

#include "test_util.h"

namespace stillmap {
namespace {

std::vector<Eigen::Vector2d> Corners(const Camera& camera) {
  std::vector<Eigen::Vector2d> corners;
  for (const double u : {0.0, 1.0}) {
    for (const double v : {0.0, 1.0}) {
      corners.emplace_back((u * (camera.width - 1) - camera.cx) / camera.fx,
                           (v * (camera.height - 1) - camera.cy) / camera.fy);
    }
  }
  return corners;
}

// Points of a room 1.5-4 m away seen from two poses (small rotation and translation, as between
// two keyframes), read by a sensor whose depth is z_true / (1 + delta) plus Gaussian noise.
std::vector<DepthPair> Pairs(const Camera& camera, const DepthCorrection& truth, double noise_m,
                             size_t count, std::mt19937* random) {
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::normal_distribution<double> gauss(0.0, 1.0);
  std::vector<DepthPair> pairs;
  while (pairs.size() < count) {
    Eigen::Isometry3d j_from_i = Eigen::Isometry3d::Identity();
    j_from_i.linear() = (Eigen::AngleAxisd(0.15 * (unit(*random) - 0.5), Eigen::Vector3d::UnitY()) *
                         Eigen::AngleAxisd(0.15 * (unit(*random) - 0.5), Eigen::Vector3d::UnitX()))
                            .toRotationMatrix();
    j_from_i.translation() =
        Eigen::Vector3d(unit(*random) - 0.5, unit(*random) - 0.5, unit(*random) - 0.5) * 0.3;
    for (int n = 0; n < 100; ++n) {
      const double u = unit(*random) * camera.width, v = unit(*random) * camera.height;
      const Eigen::Vector2d xi((u - camera.cx) / camera.fx, (v - camera.cy) / camera.fy);
      const double zi = 1.5 + 2.5 * unit(*random);
      const Eigen::Vector3d in_j = j_from_i * (zi * Eigen::Vector3d(xi.x(), xi.y(), 1.0));
      const Eigen::Vector2d xj(in_j.x() / in_j.z(), in_j.y() / in_j.z());
      const double uj = camera.fx * xj.x() + camera.cx, vj = camera.fy * xj.y() + camera.cy;
      if (uj < 0 || vj < 0 || uj >= camera.width || vj >= camera.height) continue;
      DepthPair pair;
      pair.normalized_i = xi;
      pair.normalized_j = xj;
      pair.depth_i = zi / truth.Factor(xi.x(), xi.y()) + noise_m * gauss(*random);
      pair.depth_j = in_j.z() / truth.Factor(xj.x(), xj.y()) + noise_m * gauss(*random);
      pair.j_from_i = j_from_i;
      pairs.push_back(pair);
    }
  }
  return pairs;
}

TEST(DepthCorrectionTest, RecoversAKnownErrorFromNoisyPairs) {
  const Camera camera = testing::SmallCamera(640, 480);
  DepthCorrection truth;
  truth.coefficients = {0.02, 0.04, 0.14, -0.08, 0.13};  // about what Bonn's Xtion shows
  std::mt19937 random(7);
  std::vector<DepthPair> pairs = Pairs(camera, truth, 0.01, 20000, &random);
  // Outliers: moving points that slipped through, 5 % of the pairs.
  std::uniform_real_distribution<double> offset(-0.12, 0.12);
  for (size_t k = 0; k < pairs.size(); k += 20) pairs[k].depth_j += offset(random);
  const DepthCorrectionFit fit = FitDepthCorrection(pairs, Corners(camera), {});
  ASSERT_TRUE(fit.ok);
  for (size_t i = 0; i < 5; ++i) {
    EXPECT_NEAR(fit.correction.coefficients[i], truth.coefficients[i], 0.01) << "coefficient " << i;
  }
  EXPECT_LT(fit.spread_after_m, 0.9 * fit.spread_before_m);
  EXPECT_GT(fit.pairs_used, 18000u);
}

TEST(DepthCorrectionTest, RefusesToInventAnErrorWhereThereIsNone) {
  const Camera camera = testing::SmallCamera(640, 480);
  std::mt19937 random(11);
  const std::vector<DepthPair> pairs = Pairs(camera, DepthCorrection(), 0.01, 20000, &random);
  const DepthCorrectionFit fit = FitDepthCorrection(pairs, Corners(camera), {});
  EXPECT_FALSE(fit.ok);
  EXPECT_TRUE(fit.correction.IsIdentity());
  EXPECT_GT(fit.spread_after_m, 0.95 * fit.spread_before_m);
  // Too few pairs: no fit at all.
  const std::vector<DepthPair> few(pairs.begin(), pairs.begin() + 100);
  const DepthCorrectionFit none = FitDepthCorrection(few, Corners(camera), {});
  EXPECT_FALSE(none.ok);
  EXPECT_EQ(none.pairs_used, 0u);
}

TEST(DepthCorrectionTest, RefusesACorrectionBeyondThePlausibleRange) {
  const Camera camera = testing::SmallCamera(640, 480);
  DepthCorrection truth;
  truth.coefficients = {0.0, 0.0, 0.8, 0.0, 0.0};  // 31 % at the image's left and right edges
  std::mt19937 random(3);
  const std::vector<DepthPair> pairs = Pairs(camera, truth, 0.005, 5000, &random);
  EXPECT_FALSE(FitDepthCorrection(pairs, Corners(camera), {}).ok);
  DepthCorrectionFitOptions wide;
  wide.max_delta = 0.5;
  wide.coefficient_sigma = 1.0;
  const DepthCorrectionFit fit = FitDepthCorrection(pairs, Corners(camera), wide);
  ASSERT_TRUE(fit.ok);
  EXPECT_NEAR(fit.correction.coefficients[2], 0.8, 0.02);
}

TEST(DepthCorrectionTest, FactorImageFollowsTheModelPerPixel) {
  Camera camera = testing::SmallCamera(64, 48);
  DepthCorrection correction;
  correction.coefficients = {0.01, -0.02, 0.1, 0.05, -0.03};
  const cv::Mat factors = correction.FactorImage(camera);
  ASSERT_EQ(factors.type(), CV_32FC1);
  for (const cv::Point pixel : {cv::Point(0, 0), cv::Point(63, 47), cv::Point(20, 30)}) {
    const double x = (pixel.x - camera.cx) / camera.fx, y = (pixel.y - camera.cy) / camera.fy;
    const double expected = 1.0 + 0.01 * x - 0.02 * y + 0.1 * x * x + 0.05 * y * y - 0.03 * x * y;
    EXPECT_NEAR(factors.at<float>(pixel), expected, 1e-6);
  }
  EXPECT_EQ(cv::countNonZero(DepthCorrection().FactorImage(camera) != 1.0f), 0);
  // The cached images: the same factors, followed when the correction changes.
  camera.distortion = {0.04, -0.1, 0.0, 0.0, 0.0};
  DepthFactorImages images(camera);
  EXPECT_EQ(cv::countNonZero(images.For(DepthCorrection()) != 1.0f), 0);
  EXPECT_EQ(cv::norm(images.For(correction), correction.FactorImage(camera), cv::NORM_INF), 0.0);
  DepthCorrection other = correction;
  other.coefficients[2] = 0.2;
  EXPECT_EQ(cv::norm(images.For(other), other.FactorImage(camera), cv::NORM_INF), 0.0);
  EXPECT_GT(cv::norm(other.FactorImage(camera), correction.FactorImage(camera), cv::NORM_INF),
            0.01);
}

}  // namespace
}  // namespace stillmap
