// The furnished room of the room scenarios, its people, and the scene of every scenario.
#include "synthetic_scene.h"

#include <cmath>

#include "floor_plan.h"
#include "scene_geometry.h"
#include "scene_parts.h"

namespace stillmap::synth {
namespace {

// The room: x in [-2.5, 2.5], y in [-2, 3], z in [0, 2.7]; walls textured once over their area.
void AddRoom(StaticAdder& add) {
  const float x0 = -2.5f, x1 = 2.5f, y0 = -2.0f, y1 = 3.0f, h = 2.7f;
  TriangleMesh floor = MakeQuad({x0, y0, 0}, {x1 - x0, 0, 0}, {0, y1 - y0, 0});
  for (auto& uv : floor.uvs) uv *= 5.0f;  // carpet repeats every metre
  add("floor", floor, kCarpet);
  TriangleMesh ceiling = MakeQuad({x0, y0, h}, {0, y1 - y0, 0}, {x1 - x0, 0, 0});
  for (auto& uv : ceiling.uvs) uv *= 3.0f;
  add("ceiling", ceiling, kCeiling);
  // Wall quads: texture v runs downwards in the image, so v_edge points down the wall.
  add("wall_far", MakeQuad({x0, y1, h}, {x1 - x0, 0, 0}, {0, 0, -h}), kWallFar);
  add("wall_left", MakeQuad({x0, y0, h}, {0, y1 - y0, 0}, {0, 0, -h}), kWallLeft);
  add("wall_right", MakeQuad({x1, y1, h}, {0, y0 - y1, 0}, {0, 0, -h}), kWallRight);
  add("wall_near", MakeQuad({x1, y0, h}, {x0 - x1, 0, 0}, {0, 0, -h}), kWallNear);
}

void AddFurniture(StaticAdder& add) {
  add("desk", Table(0.3f, 2.6f, 1.5f, 0.75f, 0.74f), kWood);
  add("monitor_case", Box(0.25f, 2.75f, 1.05f, 0.6f, 0.05f, 0.38f), kPlastic);
  add("monitor_stand", Box(0.25f, 2.8f, 0.82f, 0.08f, 0.08f, 0.16f), kPlastic);
  add("monitor_screen", MakeQuad({-0.03f, 2.72f, 1.22f}, {0.56f, 0, 0}, {0, 0, -0.34f}), kScreen);
  add("keyboard", Box(0.25f, 2.45f, 0.755f, 0.45f, 0.15f, 0.025f), kPlastic);
  add("side_table", Table(1.95f, 1.2f, 0.7f, 1.2f, 0.72f), kDarkWood);
  add("cabinet", Box(1.9f, 2.55f, 0.55f, 0.9f, 0.5f, 1.1f), kDarkWood);
  add("box_on_cabinet", Box(1.75f, 2.5f, 1.22f, 0.35f, 0.3f, 0.24f), kBookFirst + 7);
  add("chair_desk", Chair(0.3f, 1.95f, 0.0f), kMetal);
  add("chair_side", Chair(1.45f, 1.2f, -kPi / 2), kMetal);
}

// Shelves along the left wall, filled with books of random thickness and height.
void AddShelves(cv::RNG& rng, StaticAdder& add) {
  TriangleMesh shelf = Box(-2.32f, 1.5f, 0.95f, 0.34f, 0.03f, 1.9f);
  shelf.Append(Box(-2.32f, 2.7f, 0.95f, 0.34f, 0.03f, 1.9f));
  for (int board = 0; board < 5; ++board) {
    shelf.Append(Box(-2.32f, 2.1f, 0.05f + 0.45f * board, 0.34f, 1.2f, 0.03f));
  }
  add("shelf", shelf, kWood);
  for (int board = 0; board < 4; ++board) {
    TriangleMesh books;
    float y = 1.54f;
    while (y < 2.6f) {
      const float thickness = static_cast<float>(rng.uniform(0.03, 0.08));
      const float height = static_cast<float>(rng.uniform(0.22, 0.38));
      books.Append(Box(-2.35f, y + thickness / 2, 0.065f + 0.45f * board + height / 2, 0.24f,
                       thickness * 0.95f, height, 0.2f));
      y += thickness + static_cast<float>(rng.uniform(0.0, 0.04));
    }
    add("books_" + std::to_string(board), books, static_cast<std::uint16_t>(kBookFirst + board));
  }
}

// look_alike: a second shelf with the same books on the near wall, a twin of the first: two
// places that look the same and must never be joined.
void AddTwinShelf(Scene* scene, StaticAdder& add) {
  std::vector<StaticObject> twins;
  for (const StaticObject& object : scene->statics) {
    if (object.name != "shelf" && object.name.rfind("books_", 0) != 0) continue;
    StaticObject twin = object;
    twin.name = object.name + "_twin";
    twin.id = add.next_id++;
    // Turned from facing +x (left wall) to facing +y (near wall), 0.5 m right of the middle.
    const Eigen::Matrix3f turn = Eigen::AngleAxisf(kPi / 2, Eigen::Vector3f::UnitZ()).matrix();
    for (Eigen::Vector3f& vertex : twin.mesh.vertices) {
      vertex = turn * vertex + Eigen::Vector3f(2.6f, 0.5f, 0.0f);
    }
    twins.push_back(std::move(twin));
  }
  for (StaticObject& twin : twins) scene->statics.push_back(std::move(twin));
}

void AddPeople(const std::string& scenario, cv::RNG& rng, Scene* scene) {
  PeopleAdder add(scene, rng);
  if (scenario.rfind("walking", 0) == 0) {
    // Across the view, clear of the side chair (x >= 1.22); then towards the camera and back,
    // stopping short of the first one's line (y = 0.9).
    add.Walker({-2.1f, 0.9f}, {1.0f, 0.9f}, 1.1f);
    add.Walker({-1.2f, 2.2f}, {-0.5f, 1.25f}, 0.9f, 1.0f);
  } else if (scenario == "loop") {
    // Two people walking along the far and the left wall, outside the camera's circle.
    add.Walker({-1.6f, 2.35f}, {1.3f, 2.35f}, 0.8f);
    add.Walker({-1.85f, -1.5f}, {-1.85f, 1.3f}, 0.7f, 2.0f);
  } else if (scenario == "crowd_start") {
    // Three people in view from the first frame, crossing it early.
    add.Walker({-1.9f, 1.0f}, {1.0f, 1.0f}, 1.0f, 1.2f);
    add.Walker({-1.3f, 2.1f}, {-0.4f, 1.3f}, 0.8f, 0.4f);   // towards the camera
    add.Walker({1.0f, 1.45f}, {-1.6f, 1.45f}, 0.9f, 0.9f);  // the other way, behind the first
  } else if (scenario == "lens_pass") {
    // One person walking in the room, and one crossing 0.4-0.7 m in front of the lens once
    // (at about 3.75 s), filling most of the image; the room's walls hide them outside it.
    add.Walker({-2.1f, 1.2f}, {1.0f, 1.2f}, 0.9f);
    add.Walker({-4.5f, -0.35f}, {4.5f, -0.35f}, 1.2f);
  } else if (scenario == "stop_and_go") {
    // A person walks in from the left (out of view at first), stands 4 s, and walks out.
    MovingObject& person = add.Walker({-3.2f, 1.3f}, {-0.2f, 1.3f}, 1.0f);
    person.motion = Motion::kStopAndGo;
    person.stand_s = 4.0f;
  } else if (scenario == "busy_office") {
    // What a busy office recording holds at once (issue 51): two people crossing the view from
    // the first frame, one crossing 0.4-0.7 m before the lens (at about 5 s) and one walking in
    // to stand still for 4 s, in front of the far wall.
    add.Walker({-1.9f, 1.0f}, {1.0f, 1.0f}, 1.0f, 1.2f);
    add.Walker({1.0f, 1.6f}, {-1.6f, 1.6f}, 0.8f, 0.9f);
    add.Walker({-6.0f, -0.35f}, {4.5f, -0.35f}, 1.2f);
    MovingObject& standing = add.Walker({-3.2f, 2.1f}, {-0.9f, 2.1f}, 1.0f);
    standing.motion = Motion::kStopAndGo;
    standing.stand_s = 4.0f;
  } else if (scenario == "sitting") {
    add.Sitter({0.3f, 1.93f, 0.5f}, 0.0f);
    add.Sitter({1.43f, 1.2f, 0.5f}, -kPi / 2, 2.0f);
  } else if (scenario == "carried_object") {
    add.Walker({-1.8f, 0.3f}, {1.2f, 0.5f}, 0.7f).motion = Motion::kCarry;
    add.CarriedBook();
  }
}

}  // namespace

Scene BuildScene(const std::string& scenario, std::uint64_t seed) {
  cv::RNG rng(seed * 7919 + 17);
  Scene scene;
  AddMaterials(rng, &scene);
  if (IsFloorScenario(scenario)) {
    AddFloor(rng, &scene);
    return scene;
  }
  StaticAdder add(&scene);
  AddRoom(add);
  AddFurniture(add);
  AddShelves(rng, add);
  if (scenario == "look_alike") AddTwinShelf(&scene, add);
  AddPeople(scenario, rng, &scene);
  return scene;
}

void BoundStatics(Scene* scene) {
  for (StaticObject& object : scene->statics) {
    Eigen::AlignedBox3f box;
    for (const Eigen::Vector3f& vertex : object.mesh.vertices) box.extend(vertex);
    object.bound_center = box.center();
    object.bound_radius = 0.5f * box.diagonal().norm();
  }
}

}  // namespace stillmap::synth
