// A deterministic CPU z-buffer rasterizer for pinhole cameras: near-plane clipping, perspective-
// correct texture coordinates, deferred shading. No GPU and no display.
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <opencv2/core.hpp>
#include <vector>

#include "stillmap/io/camera.h"
#include "stillmap/synth/mesh.h"

namespace stillmap {

// A texture and how light falls on it.
struct Material {
  cv::Mat texture;        // CV_8UC3 BGR, sampled bilinearly, repeating
  float ambient = 0.55f;  // shade = ambient + diffuse * max(0, n . light)
  float diffuse = 0.45f;
};

// What the rasterizer keeps per pixel of the nearest surface.
struct RasterBuffers {
  cv::Mat depth;          // CV_32FC1 camera z [m], 0 = nothing drawn
  cv::Mat object_id;      // CV_16UC1, 0 = nothing drawn
  cv::Mat material_id;    // CV_16UC1
  cv::Mat uv;             // CV_32FC2 texture coordinates
  cv::Mat shade;          // CV_32FC1 Lambert factor
  cv::Mat cos_incidence;  // CV_32FC1 |cos| of the angle between viewing ray and normal
};

class Rasterizer {
 public:
  // Pixel (u, v) is the projection fx * x / z + cx (no distortion: synthetic cameras are ideal).
  explicit Rasterizer(const Camera& camera, float near_plane = 0.05f);

  // Clears every buffer.
  void Clear();

  // Draws `mesh` (vertices in the world frame after `world_from_mesh`) seen by a camera at
  // `camera_from_world`. `object_id` > 0 labels its pixels; `light_in_world` is a unit direction
  // towards the light. Back faces are drawn too (thin objects are seen from both sides).
  void Draw(const TriangleMesh& mesh, const Eigen::Isometry3f& world_from_mesh,
            const Eigen::Isometry3f& camera_from_world, std::uint16_t object_id,
            std::uint16_t material_id, const Eigen::Vector3f& light_in_world);

  // Colors the drawn pixels from their materials (BGR, 8 bit); background stays black.
  cv::Mat Shade(const std::vector<Material>& materials) const;

  const RasterBuffers& buffers() const { return buffers_; }
  const Camera& camera() const { return camera_; }

 private:
  Camera camera_;
  float near_plane_;
  RasterBuffers buffers_;
};

// Bilinear, repeating texture lookup (u right, v down in the image), BGR as floats.
Eigen::Vector3f SampleTexture(const cv::Mat& texture, float u, float v);

}  // namespace stillmap
