// The floor's normal in one depth image against exact truth: a camera 0.9 m above a floor,
// pitched 8 degrees down and rolled 0.3 degrees, sees the floor, a wall 3 m ahead, a table top
// 0.7 m high and a person standing close, in depth cast ray by ray with Kinect-like noise. The
// floor's normal must come out as the camera's true up from a guess 1 degree off; a view with no
// floor in it gives nothing; the median of many normals keeps away from a few tilted ones.
#include "stillmap/tracking/floor_normal.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <limits>
#include <random>

#include "stillmap/io/camera.h"
#include "stillmap/synth/synthetic.h"

namespace stillmap {
namespace {

constexpr double kDeg = M_PI / 180.0;

// The camera's frame in a floor frame (z up, the camera at the origin 0.9 m above the floor,
// looking along +x): optical z forward, x right, y down, then pitched and rolled.
Eigen::Matrix3d FloorFromCamera(double pitch_down_deg, double roll_deg) {
  Eigen::Matrix3d level;
  level.col(0) = -Eigen::Vector3d::UnitY();  // image right
  level.col(1) = -Eigen::Vector3d::UnitZ();  // image down
  level.col(2) = Eigen::Vector3d::UnitX();   // forward
  return Eigen::AngleAxisd(pitch_down_deg * kDeg, Eigen::Vector3d::UnitY()).toRotationMatrix() *
         level * Eigen::AngleAxisd(roll_deg * kDeg, Eigen::Vector3d::UnitZ()).toRotationMatrix();
}

// The nearest hit along a ray from the camera (floor frame) among the scene's surfaces [m along
// the ray], or infinity.
double CastScene(const Eigen::Vector3d& ray, bool with_floor) {
  double nearest = std::numeric_limits<double>::infinity();
  auto take = [&nearest](double t) {
    if (t > 0.0 && t < nearest) nearest = t;
  };
  if (with_floor && ray.z() < 0.0) take(-0.9 / ray.z());  // the floor, z = -0.9
  if (ray.x() > 0.0) take(3.0 / ray.x());                 // the wall, x = 3
  if (ray.z() < 0.0) {                                    // a table top 0.7 m high, 1.2 m wide
    const double t = -0.2 / ray.z();
    const Eigen::Vector3d p = t * ray;
    if (p.x() > 1.5 && p.x() < 2.2 && p.y() > 0.2 && p.y() < 1.4) take(t);
  }
  // A person: a vertical cylinder of radius 0.2 m at (1.2, -0.5), 1.8 m tall.
  const Eigen::Vector2d c(1.2, -0.5), d(ray.x(), ray.y());
  const double a = d.squaredNorm(), b = -2.0 * d.dot(c), cc = c.squaredNorm() - 0.04;
  const double disc = b * b - 4.0 * a * cc;
  if (disc >= 0.0) {
    const double t = (-b - std::sqrt(disc)) / (2.0 * a);
    if (t > 0.0 && (t * ray).z() < 0.9) take(t);
  }
  return nearest;
}

// The depth image [m] of the scene with noise of 1.5 mm at 1 m, growing as z^2.
cv::Mat RenderDepth(const Camera& camera, const Eigen::Matrix3d& floor_from_camera, bool with_floor,
                    unsigned seed) {
  std::mt19937 random(seed);
  std::normal_distribution<double> noise(0.0, 1.0);
  cv::Mat depth_m(camera.height, camera.width, CV_32F, cv::Scalar(0.0f));
  for (int v = 0; v < camera.height; ++v) {
    for (int u = 0; u < camera.width; ++u) {
      const Eigen::Vector3d ray_in_camera((u - camera.cx) / camera.fx, (v - camera.cy) / camera.fy,
                                          1.0);
      const double t = CastScene(floor_from_camera * ray_in_camera, with_floor);
      if (!std::isfinite(t) || t > 8.0) continue;
      const double z = t;  // the ray's z in the camera is 1: t is the depth
      depth_m.at<float>(v, u) = static_cast<float>(z + 0.0015 * z * z * noise(random));
    }
  }
  return depth_m;
}

double AngleDeg(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::atan2(a.cross(b).norm(), a.dot(b)) / kDeg;
}

TEST(FloorNormalTest, FindsTheCamerasUpFromTheFloorAmongOtherSurfaces) {
  const Camera camera = SynthCamera();
  const Eigen::Matrix3d floor_from_camera = FloorFromCamera(8.0, 0.3);
  const Eigen::Vector3d true_up = floor_from_camera.transpose() * Eigen::Vector3d::UnitZ();
  const Eigen::Vector3d guess = Eigen::AngleAxisd(1.0 * kDeg, Eigen::Vector3d::UnitZ()) *
                                (Eigen::AngleAxisd(0.7 * kDeg, Eigen::Vector3d::UnitX()) * true_up);
  ASSERT_GT(AngleDeg(guess, true_up), 0.7);
  const cv::Mat depth_m = RenderDepth(camera, floor_from_camera, true, 7);
  const std::optional<Eigen::Vector3d> normal =
      FloorNormalInCamera(PixelRays(camera), depth_m, guess, FloorNormalOptions{});
  ASSERT_TRUE(normal.has_value());
  EXPECT_NEAR(normal->norm(), 1.0, 1e-9);
  EXPECT_LT(AngleDeg(*normal, true_up), 0.02) << normal->transpose();
}

TEST(FloorNormalTest, AViewWithoutFloorGivesNothing) {
  const Camera camera = SynthCamera();
  // Level, so that the floor would be in the lower half: left out of the scene. The lowest
  // layer is then the bottom of the wall, the table and the person: none of it level and wide.
  const Eigen::Matrix3d floor_from_camera = FloorFromCamera(0.0, 0.0);
  const Eigen::Vector3d up = floor_from_camera.transpose() * Eigen::Vector3d::UnitZ();
  const cv::Mat depth_m = RenderDepth(camera, floor_from_camera, false, 8);
  FloorNormalOptions options;
  EXPECT_FALSE(FloorNormalInCamera(PixelRays(camera), depth_m, up, options).has_value());
  // An empty image, and rays that do not fit the image, give nothing too.
  EXPECT_FALSE(FloorNormalInCamera(PixelRays(camera), cv::Mat(), up, options).has_value());
  EXPECT_FALSE(FloorNormalInCamera({}, depth_m, up, options).has_value());
}

TEST(FloorNormalTest, MedianDirectionKeepsAwayFromAFewTiltedNormals) {
  const Eigen::Vector3d truth = Eigen::Vector3d(0.02, -0.99, 0.14).normalized();
  std::mt19937 random(3);
  std::normal_distribution<double> jitter(0.0, 0.01 * kDeg);
  std::vector<Eigen::Vector3d> normals;
  normals.reserve(25);
  for (int i = 0; i < 20; ++i) {
    normals.push_back(Eigen::AngleAxisd(jitter(random), Eigen::Vector3d::UnitX()) *
                      (Eigen::AngleAxisd(jitter(random), Eigen::Vector3d::UnitZ()) * truth));
  }
  for (int i = 0; i < 5; ++i) {  // a ramp or a sloped table, 10 degrees off
    normals.push_back(Eigen::AngleAxisd(10.0 * kDeg, Eigen::Vector3d::UnitZ()) * truth);
  }
  const std::optional<Eigen::Vector3d> median = MedianDirection(normals);
  ASSERT_TRUE(median.has_value());
  EXPECT_LT(AngleDeg(*median, truth), 0.1);
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3d& n : normals) mean += n;
  EXPECT_GT(AngleDeg(mean.normalized(), truth), 1.0);  // what a mean would have done
  EXPECT_FALSE(MedianDirection({}).has_value());
}

}  // namespace
}  // namespace stillmap
