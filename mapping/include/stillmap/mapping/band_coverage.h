// Which heights of the grid's band the keyframes' rays crossed over each grid cell, in thin
// layers. A flat top seen only edge-on from just above it (a table's top at 0.74 m from a camera
// at 0.90 m: the sensor returns nothing at grazing angles) is never hit, and the rays that pass
// under it and over it make its cells free in the OctoMap, whose voxels are thicker than the
// top. In layers of a centimetre the top is what it is: a hole in one view's fan of rays over the
// cell, with rays of that view under it and over it, that no view's rays crossed. Layers between
// the fans of different views (one looked at the cell from afar and low, another from near and
// high) are no such hole: nothing was in the way, they were not looked at. Nor are layers a view
// looks at more steeply than a sensor's grazing limit: a flat top there would have returned a
// reading, so what its rays missed there is a patch the sensor returned nothing for (a dark or
// distant surface), not a top seen edge-on.
#pragma once

#include <cstdint>
#include <utility>
#include <vector>

#include "stillmap/io/camera.h"
#include "stillmap/mapping/map_cleaning.h"
#include "stillmap/mapping/occupancy_grid.h"

namespace stillmap {

class BandCoverage {
 public:
  // The cells, frame and band of `grid`, in layers layer_m thick [m]. A view's span over a cell
  // counts only the layers within grazing_deg [deg] of its camera's level, seen from the camera
  // (90: every layer).
  BandCoverage(const OccupancyGrid& grid, double layer_m, double grazing_deg = 90.0);

  // The rays from the view's camera to each of its readings, every `step`-th block across and
  // down, each as wide as its share of the view: crossed up to the reading, or up to max_range_m
  // [m] when it lies farther (the OctoMap's truncation; <= 0: none). `pixel_rays`: PixelRays of the
  // view's camera, whose images are `image_width` pixels wide.
  void AddView(const KeyframeView& view, const std::vector<Eigen::Vector2f>& pixel_rays,
               int image_width, double max_range_m, int step);

  // Adds what `other` (the same grid and layers, its views added apart from this one's) found:
  // views added to two coverages and joined find what they find added to one.
  void Join(const BandCoverage& other);

  // The thickest run of layers over cell (i, j) that no ray crossed and that lies between the
  // lowest and the highest layer one view's rays crossed [m]; 0 when there is none.
  double UnseenLayer(int i, int j) const;

 private:
  // Marks the layers from height z0 to z1 [m] (either order) crossed over cell (i, j), and
  // widens the view's span over it.
  void Mark(int i, int j, double z0, double z1);
  // Sets `words` per cell of `bits` over layers [first, last] of cell `index`.
  void SetLayers(std::vector<std::uint64_t>* bits, size_t index, int first, int last);
  // The view's spans into spanned_, each within the layers its camera at `centre` (grid frame
  // [m]) sees near edge-on (GrazingLayers), and cleared for the next view.
  void CloseView(const Eigen::Vector3d& centre);
  // The layers over cell `index` that a camera at `centre` sees within the grazing angle of its
  // level (first > last: none).
  std::pair<int, int> GrazingLayers(size_t index, const Eigen::Vector3d& centre) const;
  // The layers from height z0 up to z1 [m], within the band (first > last: none).
  std::pair<int, int> Layers(double z0, double z1) const;
  // The segment from a to b (grid frame [m]) walked cell by cell (Amanatides and Woo), the
  // heights it crosses widened by half_spread [rad] times the distance from a: the ray's share
  // of the view, so that a fan of rays leaves no holes of its own.
  void Walk(const Eigen::Vector3d& a, const Eigen::Vector3d& b, double half_spread);

  int width_ = 0, height_ = 0;
  double resolution_ = 0.05;
  Eigen::Vector2d origin_ = Eigen::Vector2d::Zero();
  Eigen::Isometry3d grid_from_world_ = Eigen::Isometry3d::Identity();
  double min_height_ = 0.0, layer_m_ = 0.01;
  double grazing_slope_ = 0.0;  // tan(grazing_deg); infinite at 90 degrees
  int layers_ = 0, words_ = 0;
  // Per cell (row-major as OccupancyGrid::cells), words_ each: the layers any ray crossed, and
  // those between the lowest and the highest layer one view's rays crossed.
  std::vector<std::uint64_t> crossed_, spanned_;
  // The view being added: its lowest and highest layer per cell (first > last: none yet), and
  // the cells it touched.
  std::vector<std::pair<int, int>> view_span_;
  std::vector<size_t> touched_;
};

// The free cells of `grid` over which `coverage` finds a layer at least min_layer_m thick [m]
// that no ray crossed (UnseenLayer) become unknown; returns how many.
size_t UnknownWhereLayersUnseen(const BandCoverage& coverage, double min_layer_m,
                                OccupancyGrid* grid);

}  // namespace stillmap
