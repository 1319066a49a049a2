// The static map as a colored triangle mesh for other tools (Blender, MeshLab, glTF viewers):
// the exposed faces of the occupied voxels of the voxel cloud at a coarser edge, colored by the
// voxels, written through assimp as glTF binary (.glb), OBJ or PLY.
// Chosen over PCL's surface reconstruction, which measured 10 to 300 times slower on
// bonn_crowd_a's cloud (docs/figures.md, "Measurements moved from comments").
#pragma once

#include <Eigen/Core>
#include <array>
#include <string>
#include <vector>

#include "stillmap/mapping/voxel_cloud.h"

namespace stillmap {

struct MapMeshOptions {
  bool enabled = true;
  std::string format = "glb";
  double voxel = 0.03;
  int min_points = 2;  // map points a voxel needs (isolated specks are left out)

  // Throws InputError naming the first impossible value.
  void Validate() const;
  std::string FileName() const { return "mesh." + format; }

  // Every field under its configuration key (io/option_fields.h).
  template <typename Self, typename Visitor>
  static void VisitFields(Self& self, Visitor& visit) {
    visit("enabled", self.enabled, "write the mesh (mesh.glb, or mesh.obj / mesh.ply)");
    visit("format", self.format, "glb, obj or ply");
    visit("voxel", self.voxel, "edge of the mesh's voxels [m]");
    visit("min_points", self.min_points, "map points a mesh voxel needs");
  }
};

struct ColoredMesh {
  std::vector<Eigen::Vector3f> vertices;  // [m], world frame
  std::vector<Eigen::Vector3f> colors;    // per vertex, RGB in [0, 1]
  std::vector<std::array<int, 3>> faces;  // counter-clockwise seen from outside
  size_t voxels = 0;                      // voxels meshed
};

// The boundary of the union of occupied voxels: one quad (two triangles) per voxel face whose
// neighbour is empty. Faces share their corner vertices; a vertex's color is the mean of the
// voxels whose faces meet there.
ColoredMesh VoxelSurfaceMesh(const std::vector<VoxelPoint>& points, const MapMeshOptions& options);

// Linear RGB of sRGB-encoded colour channels in [0, 1] (the camera's colours are sRGB).
Eigen::Vector3f LinearFromSrgb(const Eigen::Vector3f& srgb);

// Writes the mesh with assimp's exporter (format "glb", "obj" or "ply"; the glb's root node turns
// z up into glTF's y up, the vertices stay as given; PLY is ASCII: Debian's
// assimp 5.2 crashed reading back the binary PLY it wrote, in map_mesh_test). Throws
// std::invalid_argument for a mesh without faces, std::runtime_error naming the file and
// assimp's message when it cannot be written. A glb is written in parts (primitives of one glTF
// mesh) of at most `glb_part_vertices` vertices each: assimp's glb exporter joins identical
// vertices of each part with 272 bytes a vertex (the floor's 1.4 M-vertex mesh in one part took
// about 800 MiB to export); a mesh that fits is one part, as OBJ and PLY always are.
constexpr size_t kGlbPartVertices = size_t{1} << 18;
void WriteColoredMesh(const std::string& path, const ColoredMesh& mesh, const std::string& format,
                      size_t glb_part_vertices = kGlbPartVertices);

}  // namespace stillmap
