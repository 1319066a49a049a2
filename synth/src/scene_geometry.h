// The poses the synthetic scenes are built and moved with: pi, a translation and rotations about
// z and x (shared by synthetic_scene.cpp and scene_motion.cpp).
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

}  // namespace stillmap::synth
