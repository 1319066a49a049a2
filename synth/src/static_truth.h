// The static ground truth of a synthetic sequence: the static surfaces sampled on a grid in each
// triangle, and which samples some frame's camera sees (internal to the synthetic sequence writer).
#pragma once

#include <Eigen/Geometry>
#include <atomic>
#include <cstdint>
#include <memory>
#include <opencv2/core.hpp>
#include <vector>

#include "stillmap/io/camera.h"
#include "stillmap/io/cloud_files.h"
#include "synthetic_scene.h"

namespace stillmap::synth {

// A sphere outside a camera's view: behind it, beyond `max_z` or beside its image (with half a
// pixel of margin, the pixel rounding of MarkVisible).
bool SphereOutsideView(const Eigen::Vector3f& center_in_camera, float radius, const Camera& camera,
                       float min_z, float max_z);

class StaticTruth {
 public:
  // Samples every static surface each `spacing` metres, coloured by its texture; the samples are
  // grouped in 1 m cells so that a frame only tests those of the cells in its view.
  StaticTruth(const Scene& scene, double spacing, double max_range);

  // Marks the samples that a camera with this static-only depth sees: in the image, within range,
  // and not behind another static surface. Frames may mark at the same time.
  void MarkVisible(const Eigen::Isometry3f& camera_from_world, const cv::Mat& static_depth,
                   const Camera& camera);

  // The samples some frame saw, in the order they were sampled.
  std::vector<VoxelPoint> Seen() const;

 private:
  struct Cell {
    Eigen::Vector3f center;
    float radius = 0.0f;
    std::vector<std::uint32_t> samples;
  };

  std::vector<VoxelPoint> points_;
  std::unique_ptr<std::atomic<std::uint8_t>[]> seen_;
  std::vector<Cell> cells_;
  float max_range_;
};

}  // namespace stillmap::synth
