// How the scenes move over time: the people's walks and limbs, the carried objects, the camera's
// path of each scenario.
#include <cmath>

#include "floor_plan.h"
#include "scene_geometry.h"
#include "synthetic_scene.h"

namespace stillmap::synth {

namespace {

// Standing (kStopAndGo): at `from` before setting off, at `to` for stand_s, or back at `from`
// after the walk back.
bool Standing(const MovingObject& object, double time) {
  if (object.motion != Motion::kStopAndGo) return false;
  const float walk_s = (object.to - object.from).norm() / object.speed;
  const float t = static_cast<float>(time + object.phase_offset) - object.wait_s;
  return t < 0.0f || (t >= walk_s && t < walk_s + object.stand_s) ||
         t >= 2.0f * walk_s + object.stand_s;
}

// Position along a back-and-forth path and the direction of travel. kStopAndGo walks out and
// back once, the time it stands not counting as travel.
void WalkState(const MovingObject& object, double time, Eigen::Vector2f* position,
               Eigen::Vector2f* direction, float* distance) {
  const Eigen::Vector2f span = object.to - object.from;
  const float length = span.norm();
  float travelled = object.speed * static_cast<float>(time + object.phase_offset);
  if (object.motion == Motion::kStopAndGo) {
    travelled = object.speed *
                std::max(0.0f, static_cast<float>(time + object.phase_offset) - object.wait_s);
    const float stand_m = object.speed * object.stand_s;
    travelled = travelled < length ? travelled
                : travelled < length + stand_m
                    ? length - 1e-4f  // facing on
                    : std::min(travelled - stand_m, 2.0f * length - 1e-4f);
  }
  const float cycle = std::fmod(travelled, 2.0f * length);
  const bool outward = cycle < length;
  const float along = outward ? cycle : 2.0f * length - cycle;
  *position = object.from + span * (along / length);
  *direction = (outward ? span : -span) / length;
  *distance = travelled;
}

}  // namespace

Eigen::Isometry3f BodyPose(const Scene& scene, const MovingObject& object, double time) {
  if (object.motion == Motion::kCarried) {
    const MovingObject& carrier = scene.movers.at(static_cast<size_t>(object.carrier));
    // Held in both hands in front of the chest, tilted towards the carrier.
    return BodyPose(scene, carrier, time) * Translation(0.0f, 0.42f, 1.08f) * RotationX(-0.3f);
  }
  if (object.motion == Motion::kSit) {
    return Translation(object.seat.x(), object.seat.y(), object.seat.z() - 0.9f) *
           RotationZ(object.seat_yaw);
  }
  Eigen::Vector2f position, direction;
  float distance = 0.0f;
  WalkState(object, time, &position, &direction, &distance);
  // Standing, a person turns to face the room's open side (-y, where the cameras are).
  const float yaw = Standing(object, time) ? kPi : std::atan2(-direction.x(), direction.y());
  return Translation(position.x(), position.y(), 0.0f) * RotationZ(yaw);
}

std::vector<Eigen::Isometry3f> PartPoses(const MovingObject& object, double time) {
  if (object.motion == Motion::kCarried) return {Eigen::Isometry3f::Identity()};
  const float t = static_cast<float>(time + object.phase_offset);
  float hip_left = 0.0f, hip_right = 0.0f, knee_left = 0.0f, knee_right = 0.0f;
  float arm_left = 0.0f, arm_right = 0.0f, lean = 0.0f, head_yaw = 0.0f;
  if (object.motion == Motion::kSit) {
    // Mostly still: a slow lean, a turning head, one arm gesturing.
    hip_left = hip_right = kPi / 2;
    knee_left = knee_right = -kPi / 2;
    lean = 0.06f * std::sin(0.7f * t);
    head_yaw = 0.35f * std::sin(0.45f * t);
    arm_left = 0.3f + 0.25f * std::sin(1.3f * t);
    arm_right = 0.5f;
  } else if (Standing(object, time)) {
    // Standing: arms slightly forward, the head turning slowly.
    head_yaw = 0.3f * std::sin(0.6f * t);
    arm_left = arm_right = 0.15f;
  } else {
    // Gait: 1.4 m per stride cycle; knees bend on the forward swing.
    const float phase = 2.0f * kPi * object.speed * t / 1.4f;
    hip_left = 0.45f * std::sin(phase);
    hip_right = -hip_left;
    knee_left = -0.5f * std::max(0.0f, std::sin(phase + kPi / 2));
    knee_right = -0.5f * std::max(0.0f, std::sin(phase - kPi / 2));
    arm_left = object.motion == Motion::kCarry ? 1.2f : -0.35f * std::sin(phase);
    arm_right = object.motion == Motion::kCarry ? 1.2f : 0.35f * std::sin(phase);
  }
  const Eigen::Isometry3f upper = Translation(0, 0, 0.9f) * RotationX(lean);
  const Eigen::Isometry3f left_hip = Translation(-0.1f, 0, 0.9f) * RotationX(hip_left);
  const Eigen::Isometry3f right_hip = Translation(0.1f, 0, 0.9f) * RotationX(hip_right);
  const Eigen::Isometry3f knee = Translation(0, 0, -0.45f);
  return {
      upper,                                                        // torso
      upper * Translation(0, 0, 0.6f) * RotationZ(head_yaw),        // head
      left_hip,                                                     // left thigh
      left_hip * knee * RotationX(knee_left),                       // left shin
      right_hip,                                                    // right thigh
      right_hip * knee * RotationX(knee_right),                     // right shin
      upper * Translation(-0.25f, 0, 0.52f) * RotationX(arm_left),  // left arm
      upper * Translation(0.25f, 0, 0.52f) * RotationX(arm_right),  // right arm
  };
}

Eigen::Isometry3f CameraPose(const std::string& scenario, double time) {
  if (IsFloorScenario(scenario)) return FloorCameraPose(scenario, time);
  const float t = static_cast<float>(time);
  Eigen::Vector3f position(0.0f, -0.9f, 1.35f);  // far wall within 4 m
  Eigen::Vector3f target(0.0f, 2.0f, 1.0f);
  float roll = 0.0f;
  if (scenario == "static") {
    // An empty room scanned by a hand-held camera: sideways sweep, bobbing, looking around.
    position += Eigen::Vector3f(0.6f * std::sin(0.5f * t), 0.25f * std::sin(0.31f * t),
                                0.12f * std::sin(0.9f * t));
    target += Eigen::Vector3f(1.2f * std::sin(0.37f * t), 0.0f, 0.3f * std::sin(0.53f * t));
    roll = 0.05f * std::sin(0.8f * t);
  } else if (scenario == "walking_static" || scenario == "carried_object") {
    // Nearly still, as a tripod-less camera held in place.
    position += Eigen::Vector3f(0.004f * std::sin(1.7f * t), 0.003f * std::sin(2.3f * t),
                                0.004f * std::sin(1.3f * t));
    target += Eigen::Vector3f(0.02f * std::sin(0.9f * t), 0.0f, 0.015f * std::sin(1.1f * t));
  } else if (scenario == "walking_xyz" || scenario == "sitting" || scenario == "crowd_start" ||
             scenario == "lens_pass" || scenario == "stop_and_go" || scenario == "busy_office") {
    const bool near_lens = scenario == "lens_pass" || scenario == "busy_office";
    const float a = scenario == "sitting" || near_lens ? 0.5f : 1.0f;
    position += a * Eigen::Vector3f(0.35f * std::sin(1.05f * t), 0.25f * std::sin(0.7f * t),
                                    0.15f * std::sin(1.3f * t));
    target += a * Eigen::Vector3f(0.35f * std::sin(1.05f * t), 0.0f, 0.15f * std::sin(1.3f * t));
  } else if (scenario == "walking_rpy") {
    // Fixed position; yaw, pitch and roll swing.
    target += Eigen::Vector3f(1.2f * std::sin(0.8f * t), 0.0f, 0.6f * std::sin(1.1f * t));
    roll = 0.18f * std::sin(1.3f * t);
  } else if (scenario == "loop") {
    // Around the room's middle on an ellipse (1.5 m by 1.0 m: 8.0 m a lap) at 0.45 m/s, looking
    // outwards and a little ahead, bobbing: back at the start after 17.7 s, then on over the
    // first lap again (15 m of path in 33 s, 1000 frames).
    const float angle = -kPi / 2 + 2.0f * kPi * t / 17.7f;
    const Eigen::Vector3f middle(0.0f, 0.45f, 1.3f);
    position = middle + Eigen::Vector3f(1.5f * std::cos(angle), 1.0f * std::sin(angle),
                                        0.06f * std::sin(2.1f * t));
    const float look = angle + 0.35f;  // outwards, turned towards the direction of travel
    target = position + Eigen::Vector3f(std::cos(look), std::sin(look), -0.12f);
  } else if (scenario == "look_alike") {
    // From near the middle, turning from the shelf on the left wall past the corner to its twin
    // on the near wall and back (20 s a sweep), stepping sideways a little.
    const float yaw = 2.5f + 2.2f * (0.5f - 0.5f * std::cos(2.0f * kPi * t / 20.0f));
    position = Eigen::Vector3f(0.2f + 0.15f * std::sin(0.4f * t), 0.3f, 1.3f);
    target = position + Eigen::Vector3f(std::cos(yaw), std::sin(yaw), -0.15f);
  } else if (scenario == "walking_halfsphere") {
    // On a half sphere of 0.5 m radius, always looking at the room's middle.
    const float azimuth = 1.0f * std::sin(0.35f * t);
    const float elevation = 0.45f + 0.4f * std::sin(0.5f * t);
    position =
        Eigen::Vector3f(0.0f, -0.6f, 1.0f) +
        0.5f * Eigen::Vector3f(std::sin(azimuth) * std::cos(elevation),
                               -std::cos(azimuth) * std::cos(elevation), std::sin(elevation));
  }
  return LookAt(position, target, roll);
}

}  // namespace stillmap::synth
