#include "scene_parts.h"

#include "scene_geometry.h"
#include "scene_textures.h"

namespace stillmap::synth {

TriangleMesh Box(float x, float y, float z, float sx, float sy, float sz, float tile) {
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

std::uint16_t AddMaterial(Scene* scene, const cv::Mat& texture) {
  scene->materials.push_back({texture});
  return static_cast<std::uint16_t>(scene->materials.size() - 1);
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

}  // namespace stillmap::synth
