#include "stillmap/viewer/trajectory_plot.h"

#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>

#include "test_util.h"

namespace stillmap {
namespace {

AteResult SquareLoop() {
  std::vector<StampedPose> truth, estimate;
  for (int i = 0; i < 200; ++i) {
    const double a = i * 2.0 * M_PI / 200.0;
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.translation() = Eigen::Vector3d(2.0 * std::cos(a), std::sin(a), 0.1);
    truth.push_back({i * 0.1, pose});
    pose.translation() += Eigen::Vector3d(0.05 * std::sin(5 * a), 0.0, 0.0);
    estimate.push_back({i * 0.1, pose});
  }
  return ComputeAte(Trajectory(truth), Trajectory(estimate));
}

// Pixels whose hue is that of `kind`: anti-aliased lines blend with the white background.
int CountPixels(const cv::Mat& image, char kind) {
  int count = 0;
  for (int v = 0; v < image.rows; ++v) {
    for (int u = 0; u < image.cols; ++u) {
      const cv::Vec3b& p = image.at<cv::Vec3b>(v, u);
      const int b = p[0], g = p[1], r = p[2];
      if (kind == 'k') count += r < 60 && g < 60 && b < 60;  // black
      if (kind == 'b') count += b > r + 60 && b > g + 30;    // blue
      if (kind == 'r') count += r > b + 60 && r > g + 60;    // red
    }
  }
  return count;
}

TEST(TrajectoryPlotTest, DrawsBothTrajectoriesAndIsDeterministic) {
  const AteResult ate = SquareLoop();
  const cv::Mat image = DrawTrajectoryPlot(ate);
  ASSERT_EQ(image.size(), cv::Size(1000, 800));
  EXPECT_GT(CountPixels(image, 'k'), 2000);  // ground truth, axes, text
  EXPECT_GT(CountPixels(image, 'b'), 500);   // the estimate
  EXPECT_GT(CountPixels(image, 'r'), 200);   // the differences
  const cv::Mat again = DrawTrajectoryPlot(ate);
  EXPECT_EQ(cv::norm(image, again, cv::NORM_INF), 0.0);
}

TEST(TrajectoryPlotTest, WritesAPng) {
  testing::TempDir dir;
  WriteTrajectoryPlot(dir / "plot.png", SquareLoop());
  EXPECT_EQ(cv::imread(dir / "plot.png").size(), cv::Size(1000, 800));
}

}  // namespace
}  // namespace stillmap
