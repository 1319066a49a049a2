// The poses the synthetic scenes are built and moved with: pi, a translation and rotations about
// z and x, and a camera looking at a point (shared by the scene and motion files).
#pragma once

#include <Eigen/Geometry>

namespace stillmap::synth {

constexpr float kPi = 3.14159265358979f;

inline Eigen::Isometry3f Translation(float x, float y, float z) {
  Eigen::Isometry3f t = Eigen::Isometry3f::Identity();
  t.translation() = Eigen::Vector3f(x, y, z);
  return t;
}

inline Eigen::Isometry3f RotationZ(float angle) {
  Eigen::Isometry3f r = Eigen::Isometry3f::Identity();
  r.linear() = Eigen::AngleAxisf(angle, Eigen::Vector3f::UnitZ()).toRotationMatrix();
  return r;
}

inline Eigen::Isometry3f RotationX(float angle) {
  Eigen::Isometry3f r = Eigen::Isometry3f::Identity();
  r.linear() = Eigen::AngleAxisf(angle, Eigen::Vector3f::UnitX()).toRotationMatrix();
  return r;
}

// A camera (x right, y down, z forward) at `position` looking at `target`, x horizontal, then
// rolled about z by `roll`.
inline Eigen::Isometry3f LookAt(const Eigen::Vector3f& position, const Eigen::Vector3f& target,
                                float roll) {
  const Eigen::Vector3f z = (target - position).normalized();
  const Eigen::Vector3f x = z.cross(Eigen::Vector3f::UnitZ()).normalized();
  const Eigen::Vector3f y = z.cross(x);
  Eigen::Isometry3f world_from_camera = Eigen::Isometry3f::Identity();
  world_from_camera.linear() << x, y, z;
  world_from_camera.linear() = world_from_camera.linear() *
                               Eigen::AngleAxisf(roll, Eigen::Vector3f::UnitZ()).toRotationMatrix();
  world_from_camera.translation() = position;
  return world_from_camera;
}

}  // namespace stillmap::synth
