#include "static_truth.h"

#include <cmath>
#include <map>
#include <tuple>

#include "stillmap/synth/rasterizer.h"

namespace stillmap::synth {
namespace {

// Appends samples of one triangle every `s` metres (a grid in its plane), coloured by `material`.
void SampleTriangle(const Eigen::Vector3f& a, const Eigen::Vector3f& b, const Eigen::Vector3f& c,
                    const std::array<Eigen::Vector2f, 3>& uvs, const Material& material, float s,
                    std::vector<VoxelPoint>* points) {
  const Eigen::Vector3f ab = b - a, ac = c - a;
  const Eigen::Vector3f normal = ab.cross(ac);
  if (normal.norm() < 1e-12f) return;
  const Eigen::Vector3f e1 = ab.normalized();
  const Eigen::Vector3f e2 = normal.normalized().cross(e1);
  // Triangle in 2-D: a = (0, 0), b = (|ab|, 0), c = (ac.e1, ac.e2).
  const Eigen::Vector2f b2(ab.norm(), 0.0f), c2(ac.dot(e1), ac.dot(e2));
  const float det = b2.x() * c2.y() - c2.x() * b2.y();
  const float x_min = std::min({0.0f, b2.x(), c2.x()}), x_max = std::max({0.0f, b2.x(), c2.x()});
  const float y_min = std::min({0.0f, c2.y()}), y_max = std::max({0.0f, c2.y()});
  for (float y = y_min + s / 2; y < y_max; y += s) {
    for (float x = x_min + s / 2; x < x_max; x += s) {
      // Barycentric coordinates of (x, y): p = a + beta * ab + gamma * ac.
      const float beta = (x * c2.y() - c2.x() * y) / det;
      const float gamma = (b2.x() * y - x * b2.y()) / det;
      if (beta < 0.0f || gamma < 0.0f || beta + gamma > 1.0f) continue;
      const Eigen::Vector2f uv = (1 - beta - gamma) * uvs[0] + beta * uvs[1] + gamma * uvs[2];
      const Eigen::Vector3f bgr = SampleTexture(material.texture, uv.x(), uv.y());
      VoxelPoint point;
      point.position = a + beta * ab + gamma * ac;
      point.rgb = {static_cast<std::uint8_t>(bgr[2]), static_cast<std::uint8_t>(bgr[1]),
                   static_cast<std::uint8_t>(bgr[0])};
      point.count = 1;
      points->push_back(point);
    }
  }
}

}  // namespace

bool SphereOutsideView(const Eigen::Vector3f& q, float radius, const Camera& camera, float min_z,
                       float max_z) {
  if (q.z() + radius < min_z || q.z() - radius > max_z) return true;
  const float fx = static_cast<float>(camera.fx), fy = static_cast<float>(camera.fy);
  const float left = static_cast<float>(camera.cx) + 0.5f;  // u >= -0.5
  const float right = static_cast<float>(camera.width) - 0.5f - static_cast<float>(camera.cx);
  const float top = static_cast<float>(camera.cy) + 0.5f;
  const float bottom = static_cast<float>(camera.height) - 0.5f - static_cast<float>(camera.cy);
  // Signed distances to the four side planes through the optical centre, inside positive.
  const float margin = -radius - 1e-3f;
  return (fx * q.x() + left * q.z()) / std::hypot(fx, left) < margin ||
         (right * q.z() - fx * q.x()) / std::hypot(fx, right) < margin ||
         (fy * q.y() + top * q.z()) / std::hypot(fy, top) < margin ||
         (bottom * q.z() - fy * q.y()) / std::hypot(fy, bottom) < margin;
}

StaticTruth::StaticTruth(const Scene& scene, double spacing, double max_range)
    : max_range_(static_cast<float>(max_range)) {
  const float s = static_cast<float>(spacing);
  for (const StaticObject& object : scene.statics) {
    const TriangleMesh& mesh = object.mesh;
    for (const auto& face : mesh.faces) {
      SampleTriangle(mesh.vertices[face[0]], mesh.vertices[face[1]], mesh.vertices[face[2]],
                     {mesh.uvs[face[0]], mesh.uvs[face[1]], mesh.uvs[face[2]]},
                     scene.materials[object.material], s, &points_);
    }
  }
  seen_ = std::make_unique<std::atomic<std::uint8_t>[]>(points_.size());
  for (size_t i = 0; i < points_.size(); ++i) seen_[i].store(0, std::memory_order_relaxed);
  std::map<std::tuple<int, int, int>, size_t> cell_of;
  for (size_t i = 0; i < points_.size(); ++i) {
    const Eigen::Vector3f& p = points_[i].position;
    const auto key =
        std::make_tuple(static_cast<int>(std::floor(p.x())), static_cast<int>(std::floor(p.y())),
                        static_cast<int>(std::floor(p.z())));
    const auto [it, added] = cell_of.emplace(key, cells_.size());
    if (added) cells_.emplace_back();
    cells_[it->second].samples.push_back(static_cast<std::uint32_t>(i));
  }
  for (Cell& cell : cells_) {
    Eigen::AlignedBox3f box;
    for (std::uint32_t i : cell.samples) box.extend(points_[i].position);
    cell.center = box.center();
    cell.radius = 0.5f * box.diagonal().norm();
  }
}

void StaticTruth::MarkVisible(const Eigen::Isometry3f& camera_from_world,
                              const cv::Mat& static_depth, const Camera& camera) {
  for (const Cell& cell : cells_) {
    if (SphereOutsideView(camera_from_world * cell.center, cell.radius, camera, 0.1f, max_range_)) {
      continue;
    }
    for (std::uint32_t i : cell.samples) {
      if (seen_[i].load(std::memory_order_relaxed) != 0) continue;
      const Eigen::Vector3f q = camera_from_world * points_[i].position;
      if (q.z() < 0.1f || q.z() > max_range_) continue;
      const int u = static_cast<int>(std::lround(camera.fx * q.x() / q.z() + camera.cx));
      const int v = static_cast<int>(std::lround(camera.fy * q.y() / q.z() + camera.cy));
      if (u < 0 || v < 0 || u >= camera.width || v >= camera.height) continue;
      const float surface = static_depth.at<float>(v, u);
      if (surface > 0.0f && std::abs(surface - q.z()) < 0.01f + 0.01f * q.z()) {
        seen_[i].store(1, std::memory_order_relaxed);
      }
    }
  }
}

std::vector<VoxelPoint> StaticTruth::Seen() const {
  std::vector<VoxelPoint> seen;
  for (size_t i = 0; i < points_.size(); ++i) {
    if (seen_[i].load(std::memory_order_relaxed) != 0) seen.push_back(points_[i]);
  }
  return seen;
}

}  // namespace stillmap::synth
