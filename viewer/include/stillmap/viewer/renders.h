// Pictures of a run, drawn on the CPU with no display: a top view of the 2-D grid and two
// perspective views of the colored cloud, each with the trajectory and the fused keyframes, a
// metric reference (scale bar, or a 1 m grid on the floor) and a legend. Deterministic: the same
// input gives the same pixels.
#pragma once

#include <Eigen/Geometry>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "stillmap/mapping/occupancy_grid.h"
#include "stillmap/mapping/voxel_cloud.h"

namespace stillmap {

struct RenderInput {
  std::vector<VoxelPoint> cloud;              // world frame
  std::optional<OccupancyGrid> grid;          // gives the floor and the up direction
  std::vector<Eigen::Isometry3d> trajectory;  // camera-to-world, every tracked frame
  std::vector<Eigen::Isometry3d> keyframes;   // camera-to-world, the frames fused
  std::string title;                          // drawn at the top (the sequence's name)
};

struct RenderOptions {
  bool enabled = true;  // a build draws them (RenderViews itself ignores this)
  int width = 1200;     // [px]
  int height = 900;     // [px]

  // Every field under its configuration key (io/option_fields.h).
  template <typename Self, typename Visitor>
  static void VisitFields(Self& self, Visitor& visit) {
    visit("enabled", self.enabled, "write the renders (renders/*.png) at the end of a build");
    visit("width", self.width, "render width [px]");
    visit("height", self.height, "render height [px]");
  }
};

// "grid_top.png" (when there is a grid), "cloud_view_1.png" (from behind the first camera, 35
// degrees above the floor) and "cloud_view_2.png" (turned 60 degrees, 65 degrees above), in that
// order. Empty cloud: no cloud views.
std::vector<std::pair<std::string, cv::Mat>> RenderViews(const RenderInput& input,
                                                         const RenderOptions& options = {});

}  // namespace stillmap
