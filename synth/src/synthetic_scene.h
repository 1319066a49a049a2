// The synthetic room, its people and camera paths (internal to the synthetic sequence writer).
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <limits>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "stillmap/synth/mesh.h"
#include "stillmap/synth/rasterizer.h"

namespace stillmap::synth {

// Object ids at or above this value belong to moving things (people, carried objects) in the room
// scenarios; the floor, with more static objects, starts them at 1000 (Scene::first_dynamic_id).
constexpr std::uint16_t kFirstDynamicId = 100;

struct StaticObject {
  std::string name;
  TriangleMesh mesh;  // world frame
  std::uint16_t material = 0;
  std::uint16_t id = 0;
  Eigen::Vector3f bound_center{0, 0, 0};  // a sphere holding the mesh (BoundStatics) [m]
  float bound_radius = std::numeric_limits<float>::infinity();
};

// A rigid part of a moving object, posed per time by its owner.
struct MovingPart {
  std::string name;
  TriangleMesh mesh;  // part frame
  std::uint16_t material = 0;
};

// kStopAndGo: waits at `from` for wait_s, walks to `to`, stands there stand_s, walks back and stays
// at `from`.
enum class Motion { kWalk, kSit, kCarry, kCarried, kStopAndGo };

// A person (or a carried object) and how it moves.
struct MovingObject {
  std::string name;
  std::uint16_t id = 0;
  Motion motion = Motion::kWalk;
  std::vector<MovingPart> parts;
  Eigen::Vector2f from{0, 0},
      to{0, 0};                   // walking path ends (world x, y) [m], walked back and forth
  float speed = 1.0f;             // [m/s]
  float phase_offset = 0.0f;      // [s] along the path
  Eigen::Vector3f seat{0, 0, 0};  // sitting: hip position [m]
  float seat_yaw = 0.0f;          // sitting: facing direction [rad]
  int carrier = -1;               // kCarried: index of the person carrying it
  float stand_s = 0.0f;           // kStopAndGo: how long it stands at `to` [s]
  float wait_s = 0.0f;            // kStopAndGo: how long it waits before setting off [s]
};

struct Scene {
  std::vector<Material> materials;
  std::vector<StaticObject> statics;
  std::vector<MovingObject> movers;
  Eigen::Vector3f light_in_world{0.3f, -0.5f, 0.81f};
  std::uint16_t first_dynamic_id = kFirstDynamicId;  // static ids lie below, moving ones from it
};

// The furnished room (or the floor) and the people of `scenario`; textures and colors from `seed`.
Scene BuildScene(const std::string& scenario, std::uint64_t seed);

// Sets each static object's bounding sphere, so that renders can skip what is out of view.
void BoundStatics(Scene* scene);

// world_from_body of a moving object at `time`, and body_from_part of each of its parts.
Eigen::Isometry3f BodyPose(const Scene& scene, const MovingObject& object, double time);
std::vector<Eigen::Isometry3f> PartPoses(const MovingObject& object, double time);

// The camera of `scenario` at `time` (camera frame: x right, y down, z forward).
Eigen::Isometry3f CameraPose(const std::string& scenario, double time);

}  // namespace stillmap::synth
