#include "stillmap/synth/rasterizer.h"

#include <algorithm>
#include <cmath>

namespace stillmap {
namespace {

struct ClipVertex {
  Eigen::Vector3f position;  // camera frame [m]
  Eigen::Vector2f uv;
};

// Sutherland-Hodgman against z >= near: a triangle becomes a polygon of up to 4 vertices.
int ClipNear(const ClipVertex in[3], float near_plane, ClipVertex out[4]) {
  int count = 0;
  for (int i = 0; i < 3; ++i) {
    const ClipVertex& a = in[i];
    const ClipVertex& b = in[(i + 1) % 3];
    const bool a_inside = a.position.z() >= near_plane;
    const bool b_inside = b.position.z() >= near_plane;
    if (a_inside) out[count++] = a;
    if (a_inside != b_inside) {
      const float t = (near_plane - a.position.z()) / (b.position.z() - a.position.z());
      out[count++] = {a.position + t * (b.position - a.position), a.uv + t * (b.uv - a.uv)};
    }
  }
  return count;
}

}  // namespace

Eigen::Vector3f SampleTexture(const cv::Mat& texture, float u, float v) {
  const float x = (u - std::floor(u)) * static_cast<float>(texture.cols) - 0.5f;
  const float y = (v - std::floor(v)) * static_cast<float>(texture.rows) - 0.5f;
  const int x0 = static_cast<int>(std::floor(x)), y0 = static_cast<int>(std::floor(y));
  const float fx = x - static_cast<float>(x0), fy = y - static_cast<float>(y0);
  auto at = [&](int xi, int yi) {
    xi = (xi % texture.cols + texture.cols) % texture.cols;
    yi = (yi % texture.rows + texture.rows) % texture.rows;
    const cv::Vec3b& p = texture.at<cv::Vec3b>(yi, xi);
    return Eigen::Vector3f(p[0], p[1], p[2]);
  };
  return (1 - fy) * ((1 - fx) * at(x0, y0) + fx * at(x0 + 1, y0)) +
         fy * ((1 - fx) * at(x0, y0 + 1) + fx * at(x0 + 1, y0 + 1));
}

Rasterizer::Rasterizer(const Camera& camera, float near_plane)
    : camera_(camera), near_plane_(near_plane) {
  const cv::Size size(camera.width, camera.height);
  buffers_.depth.create(size, CV_32FC1);
  buffers_.object_id.create(size, CV_16UC1);
  buffers_.material_id.create(size, CV_16UC1);
  buffers_.uv.create(size, CV_32FC2);
  buffers_.shade.create(size, CV_32FC1);
  buffers_.cos_incidence.create(size, CV_32FC1);
  Clear();
}

void Rasterizer::Clear() {
  buffers_.depth.setTo(0.0f);
  buffers_.object_id.setTo(0);
  buffers_.material_id.setTo(0);
  buffers_.uv.setTo(cv::Scalar(0, 0));
  buffers_.shade.setTo(0.0f);
  buffers_.cos_incidence.setTo(0.0f);
}

void Rasterizer::Draw(const TriangleMesh& mesh, const Eigen::Isometry3f& world_from_mesh,
                      const Eigen::Isometry3f& camera_from_world, std::uint16_t object_id,
                      std::uint16_t material_id, const Eigen::Vector3f& light_in_world) {
  const Eigen::Isometry3f camera_from_mesh = camera_from_world * world_from_mesh;
  const float fx = static_cast<float>(camera_.fx), fy = static_cast<float>(camera_.fy);
  const float cx = static_cast<float>(camera_.cx), cy = static_cast<float>(camera_.cy);
  const int width = camera_.width, height = camera_.height;
  std::vector<Eigen::Vector3f> in_camera(mesh.vertices.size());
  for (size_t i = 0; i < mesh.vertices.size(); ++i)
    in_camera[i] = camera_from_mesh * mesh.vertices[i];

  for (const auto& face : mesh.faces) {
    const ClipVertex triangle[3] = {{in_camera[face[0]], mesh.uvs[face[0]]},
                                    {in_camera[face[1]], mesh.uvs[face[1]]},
                                    {in_camera[face[2]], mesh.uvs[face[2]]}};
    if (triangle[0].position.z() < near_plane_ && triangle[1].position.z() < near_plane_ &&
        triangle[2].position.z() < near_plane_) {
      continue;
    }
    const Eigen::Vector3f normal_in_camera = (triangle[1].position - triangle[0].position)
                                                 .cross(triangle[2].position - triangle[0].position)
                                                 .normalized();
    const Eigen::Vector3f normal_in_world =
        camera_from_world.linear().transpose() * normal_in_camera;
    // Two-sided lighting: the side facing the camera is lit.
    const float facing = normal_in_camera.dot(triangle[0].position) < 0.0f ? 1.0f : -1.0f;
    const float lambert = std::max(0.0f, facing * normal_in_world.dot(light_in_world));

    ClipVertex polygon[4];
    const int count = ClipNear(triangle, near_plane_, polygon);
    for (int fan = 1; fan + 1 < count; ++fan) {
      const ClipVertex* v[3] = {&polygon[0], &polygon[fan], &polygon[fan + 1]};
      float px[3], py[3], inverse_z[3];
      for (int k = 0; k < 3; ++k) {
        inverse_z[k] = 1.0f / v[k]->position.z();
        px[k] = fx * v[k]->position.x() * inverse_z[k] + cx;
        py[k] = fy * v[k]->position.y() * inverse_z[k] + cy;
      }
      const float area = (px[1] - px[0]) * (py[2] - py[0]) - (px[2] - px[0]) * (py[1] - py[0]);
      if (std::abs(area) < 1e-9f) continue;
      const int u_min = std::max(0, static_cast<int>(std::ceil(std::min({px[0], px[1], px[2]}))));
      const int u_max =
          std::min(width - 1, static_cast<int>(std::floor(std::max({px[0], px[1], px[2]}))));
      const int v_min = std::max(0, static_cast<int>(std::ceil(std::min({py[0], py[1], py[2]}))));
      const int v_max =
          std::min(height - 1, static_cast<int>(std::floor(std::max({py[0], py[1], py[2]}))));
      const float inverse_area = 1.0f / area;
      for (int y = v_min; y <= v_max; ++y) {
        float* depth_row = buffers_.depth.ptr<float>(y);
        for (int x = u_min; x <= u_max; ++x) {
          // Barycentric weights from edge functions at the pixel centre (x, y).
          const float w0 = ((px[1] - x) * (py[2] - y) - (px[2] - x) * (py[1] - y)) * inverse_area;
          const float w1 = ((px[2] - x) * (py[0] - y) - (px[0] - x) * (py[2] - y)) * inverse_area;
          const float w2 = 1.0f - w0 - w1;
          if (w0 < 0.0f || w1 < 0.0f || w2 < 0.0f) continue;
          // 1/z is affine in screen space; attributes divided by z are too.
          const float iz = w0 * inverse_z[0] + w1 * inverse_z[1] + w2 * inverse_z[2];
          const float z = 1.0f / iz;
          float& stored = depth_row[x];
          if (stored != 0.0f && stored <= z) continue;
          stored = z;
          const Eigen::Vector2f uv = (w0 * inverse_z[0] * v[0]->uv + w1 * inverse_z[1] * v[1]->uv +
                                      w2 * inverse_z[2] * v[2]->uv) *
                                     z;
          buffers_.object_id.at<std::uint16_t>(y, x) = object_id;
          buffers_.material_id.at<std::uint16_t>(y, x) = material_id;
          buffers_.uv.at<cv::Vec2f>(y, x) = cv::Vec2f(uv.x(), uv.y());
          buffers_.shade.at<float>(y, x) = lambert;
          const Eigen::Vector3f ray((x - cx) / fx, (y - cy) / fy, 1.0f);
          buffers_.cos_incidence.at<float>(y, x) = std::abs(normal_in_camera.dot(ray.normalized()));
        }
      }
    }
  }
}

cv::Mat Rasterizer::Shade(const std::vector<Material>& materials) const {
  cv::Mat color(buffers_.depth.size(), CV_8UC3, cv::Scalar(0, 0, 0));
  for (int y = 0; y < color.rows; ++y) {
    const float* depth = buffers_.depth.ptr<float>(y);
    for (int x = 0; x < color.cols; ++x) {
      if (depth[x] == 0.0f) continue;
      const Material& material = materials.at(buffers_.material_id.at<std::uint16_t>(y, x));
      const cv::Vec2f uv = buffers_.uv.at<cv::Vec2f>(y, x);
      const float light = material.ambient + material.diffuse * buffers_.shade.at<float>(y, x);
      const Eigen::Vector3f bgr = light * SampleTexture(material.texture, uv[0], uv[1]);
      color.at<cv::Vec3b>(y, x) = cv::Vec3b(cv::saturate_cast<std::uint8_t>(bgr[0]),
                                            cv::saturate_cast<std::uint8_t>(bgr[1]),
                                            cv::saturate_cast<std::uint8_t>(bgr[2]));
    }
  }
  return color;
}

}  // namespace stillmap
