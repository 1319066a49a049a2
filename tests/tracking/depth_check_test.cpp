// Paper 002's multi-view depth check against exact truth: an analytic plane with a box in front
// of it, and rendered walking people with their masks and rendering poses.
#include "stillmap/tracking/depth_check.h"

#include <gtest/gtest.h>

#include <iostream>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "rendered_sequence.h"
#include "stillmap/io/sequence.h"
#include "test_util.h"

namespace stillmap {
namespace {

// Reference points on the plane z = 2 m; the camera moves 0.1 m to the right; in the current
// image an object 1 m away covers the columns 300-399.
TEST(DepthCheckTest, PointsBehindANewObjectAreDynamic) {
  Camera camera = testing::SmallCamera(640, 480);
  std::vector<Eigen::Vector3d> points;
  for (double x = -0.9; x <= 0.9; x += 0.1) {
    for (double y = -0.6; y <= 0.6; y += 0.1) points.emplace_back(x, y, 2.0);
  }
  Eigen::Isometry3d current_from_reference = Eigen::Isometry3d::Identity();
  current_from_reference.translation() = Eigen::Vector3d(-0.1, 0.0, 0.0);
  cv::Mat depth(480, 640, CV_32FC1, cv::Scalar(2.0f));
  depth.colRange(300, 400).setTo(1.0f);
  const std::vector<DepthCheck> checks = CheckDepth(points, current_from_reference, depth, camera);
  int dynamic = 0;
  for (size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector3d q = current_from_reference * points[i];
    const double u = camera.fx * q.x() / q.z() + camera.cx;
    const double v = camera.fy * q.y() / q.z() + camera.cy;
    ASSERT_NEAR(checks[i].pixel.x, u, 1e-3);
    ASSERT_NEAR(checks[i].pixel.y, v, 1e-3);
    if (u < -0.5 || v < -0.5 || u >= 639.5 || v >= 479.5) {
      EXPECT_EQ(checks[i].verdict, DepthVerdict::kSkipped);
      continue;
    }
    const bool behind = std::lround(u) >= 300 && std::lround(u) < 400;
    EXPECT_EQ(checks[i].verdict, behind ? DepthVerdict::kDynamic : DepthVerdict::kStatic) << u;
    dynamic += behind;
  }
  EXPECT_GT(dynamic, 10);
  // Seen from 2 m to the side, the parallax (45 deg) is beyond 30 deg: every point is skipped.
  current_from_reference.translation() = Eigen::Vector3d(-2.0, 0.0, 0.0);
  for (const DepthCheck& check : CheckDepth(points, current_from_reference, depth, camera)) {
    EXPECT_EQ(check.verdict, DepthVerdict::kSkipped);
  }
}

// Rendered walking people: corners of frame k - 10 with depth, moved by the rendering poses into
// frame k. Measured: 1283 of 9267 points flagged, 1070 (83 %) of them on a person in frame k; the
// others are static points that furniture hides in frame k after the camera moved (the check
// cannot tell an occluder that moved from one the camera moved behind: issue 5 fuses it with
// the other cues).
TEST(DepthCheckTest, FlaggedPointsLieOnRenderedPeople) {
  testing::TempDir dir;
  const Sequence sequence = testing::RenderSequence(dir / "seq", "walking_xyz", 150);
  const Camera& camera = sequence.camera();
  auto mask = [&](size_t i) { return testing::MovingObjectMask(dir / "seq", sequence, i); };
  const size_t gap = 10;
  size_t flagged = 0, flagged_on_people = 0, checked = 0;
  for (size_t i = gap; i < sequence.frames().size(); i += 10) {
    const Frame reference = sequence.LoadFrame(i - gap);
    const Frame current = sequence.LoadFrame(i);
    cv::Mat gray;
    cv::cvtColor(reference.color, gray, cv::COLOR_BGR2GRAY);
    std::vector<cv::Point2f> corners;
    cv::goodFeaturesToTrack(gray, corners, 800, 0.01, 7);
    std::vector<Eigen::Vector3d> points;
    for (const cv::Point2f& corner : corners) {
      const float z = reference.depth_m.at<float>(cv::Point(corner));
      if (z <= 0.0f) continue;
      points.emplace_back(z * (corner.x - camera.cx) / camera.fx,
                          z * (corner.y - camera.cy) / camera.fy, z);
    }
    const Eigen::Isometry3d current_from_reference =
        sequence.groundtruth()->poses()[i].world_from_camera.inverse() *
        sequence.groundtruth()->poses()[i - gap].world_from_camera;
    const cv::Mat people_now = mask(i);
    for (const DepthCheck& check :
         CheckDepth(points, current_from_reference, current.depth_m, camera)) {
      if (check.verdict == DepthVerdict::kSkipped) continue;
      ++checked;
      if (check.verdict != DepthVerdict::kDynamic) continue;
      ++flagged;
      const cv::Point pixel(check.pixel);
      flagged_on_people += people_now.at<std::uint8_t>(pixel) != 0;
    }
  }
  std::cout << flagged << " of " << checked << " points flagged dynamic, " << flagged_on_people
            << " of them on a person in the current frame\n";
  ASSERT_GT(flagged, 20u);
  EXPECT_GE(flagged_on_people, 0.8 * static_cast<double>(flagged));
}

}  // namespace
}  // namespace stillmap
