#include "synthetic_scene.h"

#include <array>
#include <cmath>
#include <opencv2/imgproc.hpp>

#include "scene_geometry.h"

namespace stillmap::synth {
namespace {

// --- Procedural textures: features for ORB the way real rooms give them. ---

// Smooth value noise around `base` (BGR) plus fine grain.
cv::Mat NoiseTexture(cv::RNG& rng, const cv::Scalar& base, double amplitude, int size, int cells,
                     double grain) {
  cv::Mat coarse(cells, cells, CV_32FC3);
  rng.fill(coarse, cv::RNG::NORMAL, 0.0, amplitude);
  cv::Mat smooth;
  cv::resize(coarse, smooth, cv::Size(size, size), 0, 0, cv::INTER_CUBIC);
  cv::Mat fine(size, size, CV_32FC3);
  rng.fill(fine, cv::RNG::NORMAL, 0.0, grain);
  cv::Mat texture = smooth + fine + base;
  texture.convertTo(texture, CV_8UC3);
  return texture;
}

cv::Scalar RandomColor(cv::RNG& rng, int lo, int hi) {
  return cv::Scalar(rng.uniform(lo, hi), rng.uniform(lo, hi), rng.uniform(lo, hi));
}

// A painted wall with posters, frames and notes: high-contrast corners and edges.
cv::Mat WallTexture(cv::RNG& rng, const cv::Scalar& paint) {
  cv::Mat wall = NoiseTexture(rng, paint, 6.0, 1024, 12, 3.0);
  const int posters = rng.uniform(5, 9);
  for (int p = 0; p < posters; ++p) {
    const int w = rng.uniform(90, 220), h = rng.uniform(90, 260);
    const int x = rng.uniform(10, 1024 - w - 10), y = rng.uniform(40, 700 - h);
    const cv::Rect rect(x, y, w, h);
    cv::rectangle(wall, rect, RandomColor(rng, 20, 235), cv::FILLED);
    for (int s = 0; s < 12; ++s) {
      const cv::Point a(x + rng.uniform(0, w), y + rng.uniform(0, h));
      const cv::Scalar color = RandomColor(rng, 0, 255);
      switch (rng.uniform(0, 3)) {
        case 0:
          cv::circle(wall, a, rng.uniform(5, 30), color, cv::FILLED);
          break;
        case 1:
          cv::rectangle(wall, a, cv::Point(a.x + rng.uniform(8, 40), a.y + rng.uniform(8, 40)),
                        color, cv::FILLED);
          break;
        default:
          cv::putText(wall, "STILL", a, cv::FONT_HERSHEY_DUPLEX, 0.6 + rng.uniform(0.0, 1.0), color,
                      2);
      }
    }
    cv::rectangle(wall, rect, cv::Scalar(20, 20, 20), 4);
  }
  cv::rectangle(wall, cv::Rect(0, 985, 1024, 39), cv::Scalar(60, 70, 80), cv::FILLED);  // skirting
  return wall;
}

cv::Mat WoodTexture(cv::RNG& rng, const cv::Scalar& tone) {
  cv::Mat wood(256, 256, CV_8UC3);
  const double frequency = rng.uniform(0.15, 0.3);
  cv::Mat warp = NoiseTexture(rng, cv::Scalar::all(0), 40.0, 256, 6, 0.0);
  for (int y = 0; y < 256; ++y) {
    for (int x = 0; x < 256; ++x) {
      const double grain =
          0.5 + 0.5 * std::sin(frequency * (y + 0.3 * warp.at<cv::Vec3b>(y, x)[0]));
      for (int c = 0; c < 3; ++c) {
        wood.at<cv::Vec3b>(y, x)[c] =
            cv::saturate_cast<uchar>(tone[c] * (0.7 + 0.45 * grain) + rng.gaussian(4.0));
      }
    }
  }
  return wood;
}

cv::Mat StripeTexture(cv::RNG& rng, const cv::Scalar& a, const cv::Scalar& b) {
  cv::Mat cloth = NoiseTexture(rng, a, 5.0, 128, 8, 6.0);
  const int period = rng.uniform(10, 26);
  for (int y = 0; y < 128; y += period) {
    cv::rectangle(cloth, cv::Rect(0, y, 128, period / 2), b, cv::FILLED);
  }
  cv::Mat grain(128, 128, CV_8UC3);
  rng.fill(grain, cv::RNG::UNIFORM, 0, 12);
  return cloth + grain;
}

cv::Mat ScreenTexture(cv::RNG& rng) {
  cv::Mat screen(256, 384, CV_8UC3, cv::Scalar(40, 30, 25));
  for (int w = 0; w < 6; ++w) {
    const cv::Rect window(rng.uniform(0, 300), rng.uniform(0, 190), rng.uniform(60, 160),
                          rng.uniform(40, 120));
    cv::rectangle(screen, window, RandomColor(rng, 60, 250), cv::FILLED);
    cv::rectangle(screen, window, cv::Scalar(10, 10, 10), 3);
    for (int line = window.y + 14; line < window.y + window.height - 6; line += 12) {
      cv::line(screen, {window.x + 8, line}, {window.x + rng.uniform(20, 150), line},
               cv::Scalar(15, 15, 15), 2);
    }
  }
  return screen;
}

// --- Geometry helpers (scene_geometry.h: Translation, RotationZ, RotationX) ---

TriangleMesh Box(float x, float y, float z, float sx, float sy, float sz, float tile = 0.5f) {
  return MakeBox(Eigen::Vector3f(x, y, z), Eigen::Vector3f(sx, sy, sz), tile);
}

// A table: top at height `height`, legs at the corners.
TriangleMesh Table(float x, float y, float width, float depth, float height) {
  TriangleMesh table = Box(x, y, height - 0.02f, width, depth, 0.04f);
  for (float sx : {-1.0f, 1.0f}) {
    for (float sy : {-1.0f, 1.0f}) {
      table.Append(Box(x + sx * (width / 2 - 0.05f), y + sy * (depth / 2 - 0.05f),
                       (height - 0.04f) / 2, 0.05f, 0.05f, height - 0.04f));
    }
  }
  return table;
}

// A chair facing `yaw` (its back behind the seat).
TriangleMesh Chair(float x, float y, float yaw) {
  TriangleMesh chair = Box(0, 0, 0.45f, 0.46f, 0.46f, 0.05f);
  chair.Append(Box(0, -0.21f, 0.72f, 0.46f, 0.04f, 0.5f));
  for (float sx : {-1.0f, 1.0f}) {
    for (float sy : {-1.0f, 1.0f})
      chair.Append(Box(sx * 0.2f, sy * 0.2f, 0.21f, 0.04f, 0.04f, 0.42f));
  }
  TriangleMesh placed;
  placed.Append(chair, Translation(x, y, 0) * RotationZ(yaw));
  return placed;
}

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

// A face on skin, for the head's texture (u around from the front, v from the top): hair on top
// and at the back, eyes, brows and a mouth at the front (u near 0 and 1).
cv::Mat FaceTexture(cv::RNG& rng, const cv::Scalar& skin, const cv::Scalar& hair) {
  cv::Mat face = NoiseTexture(rng, skin, 6.0, 128, 6, 3.0);
  cv::rectangle(face, cv::Rect(0, 0, 128, 40), hair, cv::FILLED);  // top
  cv::rectangle(face, cv::Rect(30, 0, 68, 80), hair, cv::FILLED);  // back of the head
  for (int side : {-1, 1}) {
    const int u = side < 0 ? 121 : 7;  // +-0.055 of a turn from the front
    cv::ellipse(face, {u, 58}, {4, 3}, 0, 0, 360, cv::Scalar(245, 245, 245), cv::FILLED);
    cv::circle(face, {u, 58}, 2, cv::Scalar(40, 30, 20), cv::FILLED);
    cv::line(face, {u - 5, 51}, {u + 5, 51}, hair, 2);
  }
  cv::line(face, {0, 82}, {6, 82}, cv::Scalar(60, 60, 150), 2);  // mouth, across the seam
  cv::line(face, {122, 82}, {127, 82}, cv::Scalar(60, 60, 150), 2);
  return face;
}

// Adds a person with rounded limbs (capsules), a tapered torso and a head with a face; shirt,
// trousers, skin and hair of their own colors.
MovingObject MakePerson(Scene* scene, cv::RNG& rng, const std::string& name, std::uint16_t id) {
  auto add_material = [scene](const cv::Mat& texture) {
    scene->materials.push_back({texture, 0.55f, 0.45f});
    return static_cast<std::uint16_t>(scene->materials.size() - 1);
  };
  const std::uint16_t shirt =
      add_material(StripeTexture(rng, RandomColor(rng, 30, 220), RandomColor(rng, 30, 220)));
  const std::uint16_t trousers =
      add_material(NoiseTexture(rng, RandomColor(rng, 30, 110), 12.0, 128, 10, 10.0));
  const cv::Scalar skin = std::vector<cv::Scalar>{
      {150, 180, 230}, {110, 150, 200}, {60, 90, 140}}[static_cast<size_t>(rng.uniform(0, 3))];
  const std::uint16_t head = add_material(FaceTexture(rng, skin, RandomColor(rng, 10, 70)));
  MovingObject person;
  person.name = name;
  person.id = id;
  // Torso from the hips (part origin) up to the neck, wider at the shoulders (z, rx, ry), top
  // first.
  TriangleMesh torso = MakeRevolved({{0.60f, 0.05f, 0.05f},
                                     {0.58f, 0.12f, 0.08f},
                                     {0.52f, 0.20f, 0.11f},
                                     {0.42f, 0.19f, 0.12f},
                                     {0.22f, 0.15f, 0.10f},
                                     {0.05f, 0.17f, 0.11f},
                                     {0.00f, 0.14f, 0.09f}},
                                    16);
  for (auto& uv : torso.uvs) uv = Eigen::Vector2f(uv.x() * 2.0f, uv.y() * 2.4f);
  TriangleMesh head_mesh;
  head_mesh.Append(MakeCapsule(0.05f, 0.1f, 10),
                   Eigen::Isometry3f(Eigen::Translation3f(0, 0, 0.08f)));
  head_mesh.Append(MakeEllipsoid({0.08f, 0.095f, 0.115f}),
                   Eigen::Isometry3f(Eigen::Translation3f(0, 0.01f, 0.15f)));
  TriangleMesh shin = MakeCapsule(0.055f, 0.42f);
  shin.Append(Box(0, 0.04f, -0.42f, 0.1f, 0.25f, 0.07f, 0.25f));  // shoe
  TriangleMesh arm = MakeCapsule(0.045f, 0.56f);
  arm.Append(MakeEllipsoid({0.035f, 0.045f, 0.06f}, 10),
             Eigen::Isometry3f(Eigen::Translation3f(0, 0, -0.6f)));  // hand
  // Parts in their own frames, pivots at the joints (body frame: feet on z = 0, facing +y).
  person.parts = {
      {"torso", torso, shirt},
      {"head", head_mesh, head},
      {"left_thigh", MakeCapsule(0.075f, 0.46f), trousers},
      {"left_shin", shin, trousers},
      {"right_thigh", MakeCapsule(0.075f, 0.46f), trousers},
      {"right_shin", shin, trousers},
      {"left_arm", arm, shirt},
      {"right_arm", arm, shirt},
  };
  return person;
}

}  // namespace

namespace {

void AddMaterials(cv::RNG& rng, Scene* scene) {
  std::vector<Material>& materials = scene->materials;
  materials.resize(kBookFirst + kBookCount);
  materials[kCarpet] = {NoiseTexture(rng, cv::Scalar(70, 80, 95), 18.0, 256, 16, 16.0)};
  materials[kCeiling] = {NoiseTexture(rng, cv::Scalar(225, 228, 230), 4.0, 256, 8, 2.0)};
  materials[kWallFar] = {WallTexture(rng, cv::Scalar(200, 215, 222))};
  materials[kWallLeft] = {WallTexture(rng, cv::Scalar(190, 200, 170))};
  materials[kWallRight] = {WallTexture(rng, cv::Scalar(175, 195, 215))};
  materials[kWallNear] = {WallTexture(rng, cv::Scalar(205, 205, 205))};
  materials[kWood] = {WoodTexture(rng, cv::Scalar(70, 120, 170))};
  materials[kDarkWood] = {WoodTexture(rng, cv::Scalar(40, 60, 95))};
  materials[kMetal] = {NoiseTexture(rng, cv::Scalar(120, 120, 125), 8.0, 64, 4, 6.0)};
  materials[kScreen] = {ScreenTexture(rng)};
  materials[kPlastic] = {NoiseTexture(rng, cv::Scalar(35, 35, 38), 4.0, 64, 4, 5.0)};
  materials[kSkin] = {NoiseTexture(rng, cv::Scalar(120, 150, 200), 10.0, 64, 4, 4.0)};
  for (int b = 0; b < kBookCount; ++b) {
    materials[kBookFirst + b] = {NoiseTexture(rng, RandomColor(rng, 20, 230), 10, 64, 4, 8)};
  }
}

// Adds the scene's static objects, each with the next id.
class StaticAdder {
 public:
  explicit StaticAdder(Scene* scene) : scene_(scene) {}
  void operator()(const std::string& name, TriangleMesh mesh, std::uint16_t material) {
    scene_->statics.push_back({name, std::move(mesh), material, next_id++});
  }
  std::uint16_t next_id = 1;

 private:
  Scene* scene_;
};

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
    const std::string name = "person_" + std::to_string(next_id_ - kFirstDynamicId);
    scene_->movers.push_back(MakePerson(scene_, rng_, name, next_id_++));
    return scene_->movers.back();
  }

  Scene* scene_;
  cv::RNG& rng_;
  std::uint16_t next_id_ = kFirstDynamicId;
};

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
  StaticAdder add(&scene);
  AddRoom(add);
  AddFurniture(add);
  AddShelves(rng, add);
  if (scenario == "look_alike") AddTwinShelf(&scene, add);
  AddPeople(scenario, rng, &scene);
  return scene;
}

}  // namespace stillmap::synth
