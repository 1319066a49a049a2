// The synthetic floor of the `floor` and `floor_lost` scenarios: four rooms, each furnished its own
// way, off a corridor loop around a closed core; the robot's camera path through it and, for
// floor_lost, when the lens is covered (internal to the synthetic sequence writer).
//
// World frame: z up, the floor at z = 0; the building spans x in [0, 16], y in [0, 14] [m]:
//   rooms A (office) and B (library) south of the corridor (y < 4), C (meeting room) and D
//   (kitchen) north of it (y > 10); the corridor loop (1.55 m wide, 37.6 m round its middle) runs
//   round the core x in [1.6, 14.4], y in [5.6, 8.4], whose walls are blank.
#pragma once

#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <string>

#include "synthetic_scene.h"

namespace stillmap::synth {

bool IsFloorScenario(const std::string& scenario);

struct FloorRect {
  float x0, y0, x1, y1;  // [m]
};

struct FloorRoom {
  const char* name;
  FloorRect inside;  // between the walls' faces
  float door_x;      // the door's middle, in the wall that faces the corridor [m]
  bool south_of_corridor;
};

constexpr float kFloorWallHeight = 2.7f;  // [m]
constexpr float kFloorDoorWidth = 1.0f;   // [m]
constexpr float kFloorDoorHeight = 2.1f;  // [m]
constexpr float kFloorWallHalf = 0.05f;   // half the thickness of inner walls [m]
constexpr FloorRect kFloorBuilding{0.0f, 0.0f, 16.0f, 14.0f};
constexpr FloorRect kFloorCore{1.6f, 5.6f, 14.4f, 8.4f};
constexpr float kCorridorSouthWall = 4.0f, kCorridorNorthWall = 10.0f;  // wall middles (y) [m]

const std::array<FloorRoom, 4>& FloorRooms();

// The floor, its furniture and its people, with materials drawn from `rng` after the shared ones.
void AddFloor(cv::RNG& rng, Scene* scene);

// The camera (x right, y down, z forward) at `time` [s]; the path takes FloorDuration() seconds.
Eigen::Isometry3f FloorCameraPose(const std::string& scenario, double time);
double FloorDuration(const std::string& scenario);
// floor_lost: the lens is covered (black, no depth) for 3 s twice: once while the camera is carried
// from room A to room B, once in the north corridor.
bool FloorLensCovered(const std::string& scenario, double time);

}  // namespace stillmap::synth
