// The building blocks of the synthetic scenes: furniture, the shared materials, and the adders
// that give static objects and people their ids (internal to the synthetic sequence writer).
#pragma once

#include <opencv2/core.hpp>
#include <stdexcept>
#include <string>

#include "synthetic_scene.h"

namespace stillmap::synth {

// An axis-aligned box centred at (x, y, z) with edge lengths (sx, sy, sz), textured per `tile` m.
TriangleMesh Box(float x, float y, float z, float sx, float sy, float sz, float tile = 0.5f);
// A table: top at height `height`, legs at the corners.
TriangleMesh Table(float x, float y, float width, float depth, float height);
// A chair at (x, y) facing `yaw` (its back behind the seat).
TriangleMesh Chair(float x, float y, float yaw);

enum MaterialIndex : std::uint16_t {
  kCarpet,
  kCeiling,
  kWallFar,
  kWallLeft,
  kWallRight,
  kWallNear,
  kWood,
  kDarkWood,
  kMetal,
  kScreen,
  kPlastic,
  kSkin,
  kBookFirst,  // kBookCount book colors follow, then per-person clothing
};
constexpr int kBookCount = 8;

// The shared materials, at the indices above.
void AddMaterials(cv::RNG& rng, Scene* scene);
// Appends a material and returns its index.
std::uint16_t AddMaterial(Scene* scene, const cv::Mat& texture);

// A person with rounded limbs, a torso and a head with a face, clothes of their own colours.
MovingObject MakePerson(Scene* scene, cv::RNG& rng, const std::string& name, std::uint16_t id);

// Adds the scene's static objects, each with the next id.
class StaticAdder {
 public:
  explicit StaticAdder(Scene* scene) : scene_(scene) {}
  void operator()(const std::string& name, TriangleMesh mesh, std::uint16_t material) {
    if (next_id >= scene_->first_dynamic_id) {
      throw std::logic_error("synthetic scene: too many static objects for its first moving id");
    }
    scene_->statics.push_back({name, std::move(mesh), material, next_id++});
  }
  std::uint16_t next_id = 1;

 private:
  Scene* scene_;
};

// Adds the scene's people (person_0, person_1, ...) and what they carry, each with the next id.
class PeopleAdder {
 public:
  PeopleAdder(Scene* scene, cv::RNG& rng) : scene_(scene), rng_(rng) {}
  // A person walking back and forth between `from` and `to` (kWalk unless changed after).
  MovingObject& Walker(const Eigen::Vector2f& from, const Eigen::Vector2f& to, float speed,
                       float phase = 0.0f) {
    MovingObject& person = Person();
    person.from = from;
    person.to = to;
    person.speed = speed;
    person.phase_offset = phase;
    return person;
  }
  // A person sitting on a chair at `seat` (hips), facing `yaw`.
  void Sitter(const Eigen::Vector3f& seat, float yaw, float phase = 0.0f) {
    MovingObject& person = Person();
    person.motion = Motion::kSit;
    person.seat = seat;
    person.seat_yaw = yaw;
    person.phase_offset = phase;
  }
  // A book in the hands of the first person.
  void CarriedBook() {
    MovingObject book;
    book.name = "book";
    book.id = next_id_++;
    book.motion = Motion::kCarried;
    book.carrier = 0;
    book.parts = {{"book", Box(0, 0, 0, 0.26f, 0.05f, 0.2f, 0.2f), kBookFirst + 5}};
    scene_->movers.push_back(book);
  }

 private:
  MovingObject& Person() {
    const std::string name = "person_" + std::to_string(next_id_ - scene_->first_dynamic_id);
    scene_->movers.push_back(MakePerson(scene_, rng_, name, next_id_++));
    return scene_->movers.back();
  }

  Scene* scene_;
  cv::RNG& rng_;
  std::uint16_t next_id_ = scene_->first_dynamic_id;
};

}  // namespace stillmap::synth
