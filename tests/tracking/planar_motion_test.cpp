// The plane of motion against exact truth: a robot's camera, 0.9 m above a floor whose vertical is
// tilted against the world's axes, pitched 8 degrees down, drives around a 6 x 4 m loop. Its
// tracked poses carry known height and tilt errors (drift); the fit must find the floor's vertical
// and the camera's height, and the poses put on the plane must lose those errors and keep their
// headings and floor positions.
#include "stillmap/tracking/planar_motion.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace stillmap {
namespace {

constexpr double kDeg = M_PI / 180.0;

// The world's vertical, 20 degrees off its z axis (a map frame that is not the floor's).
Eigen::Matrix3d WorldFromFloor() {
  return Eigen::AngleAxisd(20.0 * kDeg, Eigen::Vector3d(1.0, 1.0, 0.0).normalized())
      .toRotationMatrix();
}

// The camera of pose i of n around the loop, in the floor's frame (z up): optical z forward along
// the heading, pitched 8 degrees down, 0.9 m up.
Eigen::Isometry3d TruePoseOnFloor(int i, int n) {
  const double s = 20.0 * i / n;  // metres along the 20 m loop
  Eigen::Vector2d position;
  double heading = 0.0;
  if (s < 6.0) {
    position = {s, 0.0};
  } else if (s < 10.0) {
    position = {6.0, s - 6.0};
    heading = M_PI / 2;
  } else if (s < 16.0) {
    position = {16.0 - s, 4.0};
    heading = M_PI;
  } else {
    position = {0.0, 20.0 - s};
    heading = 3 * M_PI / 2;
  }
  // Optical frame: x right, y down, z forward; level and heading along +x first.
  Eigen::Matrix3d level;
  level << 0, 0, 1, -1, 0, 0, 0, -1, 0;
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = Eigen::AngleAxisd(heading, Eigen::Vector3d::UnitZ()).toRotationMatrix() * level *
                  Eigen::AngleAxisd(-8.0 * kDeg, Eigen::Vector3d::UnitX()).toRotationMatrix();
  pose.translation() = Eigen::Vector3d(position.x(), position.y(), 0.9);
  return pose;
}

struct Loop {
  std::vector<Eigen::Isometry3d> truth, tracked;  // world_from_camera
};

// The loop in the world frame; the tracked poses wander in height (4 cm) and tilt (0.4 and 0.3
// degrees about the camera's x and z axes) with a 2 m period, plus noise. The wander averages out
// over each leg of the loop: a tilt that kept one sign along one heading and the other along the
// opposite heading would be a tilted vertical, which no fit of the poses alone can tell apart.
Loop MakeLoop(int n) {
  Loop loop;
  std::mt19937 random(7);
  std::normal_distribution<double> noise(0.0, 1.0);
  Eigen::Isometry3d world_from_floor = Eigen::Isometry3d::Identity();
  world_from_floor.linear() = WorldFromFloor();
  world_from_floor.translation() = Eigen::Vector3d(0.3, -0.2, 1.0);
  for (int i = 0; i < n; ++i) {
    const Eigen::Isometry3d truth = world_from_floor * TruePoseOnFloor(i, n);
    const double phase = 2.0 * M_PI * (20.0 * i / n) / 2.0;  // the 2 m period
    Eigen::Isometry3d tilt = Eigen::Isometry3d::Identity();
    tilt.linear() = (Eigen::AngleAxisd((0.4 * std::sin(phase) + 0.05 * noise(random)) * kDeg,
                                       Eigen::Vector3d::UnitX()) *
                     Eigen::AngleAxisd((0.3 * std::cos(2 * phase) + 0.05 * noise(random)) * kDeg,
                                       Eigen::Vector3d::UnitZ()))
                        .toRotationMatrix();
    Eigen::Isometry3d tracked = truth * tilt;
    const double rise = 0.04 * std::sin(phase) + 0.003 * noise(random);
    tracked.translation() += rise * (world_from_floor.linear() * Eigen::Vector3d::UnitZ());
    loop.truth.push_back(truth);
    loop.tracked.push_back(tracked);
  }
  return loop;
}

double AngleDeg(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::atan2(a.cross(b).norm(), a.dot(b)) / kDeg;
}

TEST(PlanarMotionTest, FindsTheFloorsVerticalAndTheCamerasHeightFromDriftingPoses) {
  const Loop loop = MakeLoop(400);
  const std::optional<PlanarMotion> plane = FitPlanarMotion(loop.tracked);
  ASSERT_TRUE(plane);
  const Eigen::Vector3d up = WorldFromFloor() * Eigen::Vector3d::UnitZ();
  EXPECT_LT(AngleDeg(plane->up_in_world, up), 0.05);
  // Pitched 8 degrees down, the camera sees the vertical 8 degrees from its -y axis towards -z.
  const Eigen::Vector3d up_seen(0.0, -std::cos(8.0 * kDeg), -std::sin(8.0 * kDeg));
  EXPECT_LT(AngleDeg(plane->up_in_camera, up_seen), 0.05);
  const double true_height = up.dot(loop.truth.front().translation());
  EXPECT_NEAR(plane->height_m, true_height, 0.005);
  EXPECT_GT(plane->height_spread_m, 0.02);  // the drift, measured before
  EXPECT_GT(plane->tilt_spread_deg, 0.2);
  EXPECT_GT(plane->heading_spread, 0.9);  // four headings, all ways round
}

TEST(PlanarMotionTest, PosesPutOnThePlaneLoseTheirHeightAndTiltErrorsAndKeepTheirHeadings) {
  const Loop loop = MakeLoop(400);
  const PlanarMotion plane = *FitPlanarMotion(loop.tracked);
  const Eigen::Vector3d up = WorldFromFloor() * Eigen::Vector3d::UnitZ();
  double before = 0.0, after = 0.0;
  for (size_t i = 0; i < loop.tracked.size(); ++i) {
    const Eigen::Isometry3d on_plane = OntoPlane(plane, loop.tracked[i]);
    const Eigen::Vector3d error_before =
        loop.tracked[i].translation() - loop.truth[i].translation();
    const Eigen::Vector3d error_after = on_plane.translation() - loop.truth[i].translation();
    before = std::max(before, error_before.norm());
    after = std::max(after, error_after.norm());
    // Only along the vertical: the floor position is the tracked one (up to the fitted
    // vertical's own error over a few centimetres).
    EXPECT_LT((error_after - up * up.dot(error_after)).norm(), 1e-4);
    // Rotation: the tilt is the truth's; what is left is the part of the roll error that turned
    // the camera about the vertical (roll about the optical axis, 8 degrees off level: sin 8
    // degrees of it, under 0.07 degrees here).
    const Eigen::Vector3d seen = on_plane.linear().transpose() * up;
    EXPECT_LT(AngleDeg(seen, loop.truth[i].linear().transpose() * up), 0.05) << "pose " << i;
    const Eigen::AngleAxisd rotation_error(loop.truth[i].linear().transpose() * on_plane.linear());
    EXPECT_LT(rotation_error.angle() / kDeg, 0.1) << "pose " << i;
  }
  EXPECT_GT(before, 0.04);
  EXPECT_LT(after, 0.006);
}

TEST(PlanarMotionTest, AHeadingErrorIsKeptAndAPoseOnThePlaneStaysWhereItIs) {
  const Loop loop = MakeLoop(400);
  const PlanarMotion plane = *FitPlanarMotion(loop.truth);
  const Eigen::Vector3d up = WorldFromFloor() * Eigen::Vector3d::UnitZ();
  Eigen::Isometry3d turned = loop.truth[17];
  turned.linear() = Eigen::AngleAxisd(3.0 * kDeg, up).toRotationMatrix() * turned.linear();
  const Eigen::Isometry3d on_plane = OntoPlane(plane, turned);
  EXPECT_LT((on_plane.linear() - turned.linear()).norm(), 1e-9);  // a turn about up is not tilt
  EXPECT_LT((on_plane.translation() - turned.translation()).norm(), 1e-9);
}

// The true loop with 2 mm of height noise, and from pose `first` on a stretch whose height error
// grows to `rise_m` and back (a segment tilted against the rest, as a join at one place leaves
// it).
std::vector<Eigen::Isometry3d> WithDriftedStretch(const Loop& loop, size_t first, size_t count,
                                                  double rise_m) {
  std::mt19937 random(11);
  std::normal_distribution<double> noise(0.0, 0.002);
  const Eigen::Vector3d up = WorldFromFloor() * Eigen::Vector3d::UnitZ();
  std::vector<Eigen::Isometry3d> poses = loop.truth;
  for (size_t i = 0; i < poses.size(); ++i) {
    double rise = noise(random);
    if (i >= first && i < first + count) {
      rise += rise_m * std::sin(M_PI * static_cast<double>(i - first) / static_cast<double>(count));
    }
    poses[i].translation() += rise * up;
  }
  return poses;
}

TEST(PlanarMotionTest, ARobotsPosesWithOneDriftedStretchKeepToThePlaneAndAHandHeldCamerasDoNot) {
  const Loop loop = MakeLoop(400);
  // A tenth of the path rises to 30 cm: the spread is over 3 cm, the median deviation is the
  // noise's (0.67 of 2 mm for the rest, a little more with the stretch).
  const std::optional<PlanarMotion> robot = FitPlanarMotion(WithDriftedStretch(loop, 200, 40, 0.3));
  ASSERT_TRUE(robot);
  EXPECT_GT(robot->height_spread_m, 0.05);
  EXPECT_LT(robot->height_median_deviation_m, 0.003);
  EXPECT_LT(robot->tilt_median_deviation_deg, 0.01);
  EXPECT_TRUE(KeptToPlane(*robot));
  // The whole path bobbing by 8 cm, five times round: the median deviation of |0.08 sin| is
  // 0.08 sin 45 degrees.
  std::vector<Eigen::Isometry3d> bobbing = loop.truth;
  const Eigen::Vector3d up = WorldFromFloor() * Eigen::Vector3d::UnitZ();
  for (size_t i = 0; i < bobbing.size(); ++i) {
    bobbing[i].translation() += 0.08 * std::sin(2.0 * M_PI * 5.0 * i / 400.0) * up;
  }
  const std::optional<PlanarMotion> hand = FitPlanarMotion(bobbing);
  ASSERT_TRUE(hand);
  EXPECT_NEAR(hand->height_median_deviation_m, 0.08 * std::sin(M_PI / 4), 0.01);
  EXPECT_FALSE(KeptToPlane(*hand));
  // The drifting loop above: its 4 cm rise's median deviation is 4 sin 45 degrees = 2.8 cm, its
  // tilts of 0.4 and 0.3 degrees well within one degree.
  const PlanarMotion drifting = *FitPlanarMotion(loop.tracked);
  EXPECT_NEAR(drifting.height_median_deviation_m, 0.04 * std::sin(M_PI / 4), 0.003);
  EXPECT_LT(drifting.tilt_median_deviation_deg, 0.5);
  EXPECT_TRUE(KeptToPlane(drifting));
}

TEST(PlanarMotionTest, ACameraThatNeverTurnedLeavesTheVerticalOpen) {
  std::vector<Eigen::Isometry3d> straight;
  straight.reserve(100);
  for (int i = 0; i < 100; ++i) straight.push_back(TruePoseOnFloor(i, 400));  // the first 6 m
  EXPECT_FALSE(FitPlanarMotion(straight));
  EXPECT_FALSE(FitPlanarMotion({}));
}

}  // namespace
}  // namespace stillmap
