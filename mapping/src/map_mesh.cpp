#include "stillmap/mapping/map_mesh.h"

#include <assimp/scene.h>
#include <fmt/format.h>

#include <algorithm>
#include <assimp/Exporter.hpp>
#include <cmath>
#include <cstdint>
#include <memory>
#include <stdexcept>
#include <unordered_map>

#include "stillmap/io/error.h"
#include "stillmap/io/option_names.h"
#include "voxel_key.h"

namespace stillmap {

namespace {

struct Cell {
  Eigen::Vector3f color_sum = Eigen::Vector3f::Zero();
  std::uint32_t points = 0;
};

// The rotation from a z-up frame to glTF's y-up one: (x, y, z) -> (x, z, -y).
aiMatrix4x4 GltfFromMap() {
  return aiMatrix4x4(1, 0, 0, 0,   //
                     0, 0, 1, 0,   //
                     0, -1, 0, 0,  //
                     0, 0, 0, 1);
}

// The faces from `begin` on that fit in a part of at most `max_vertices` vertices, as an aiMesh
// whose vertices are numbered in the order the faces first use them (a mesh in one part keeps its
// numbering: VoxelSurfaceMesh makes vertices in that order); `*end` is where the next part
// begins. `local` (-1 for every vertex of the mesh) is left as found. Arrays are allocated with
// new[] (the mesh with new) because aiMesh's destructor frees them so.
aiMesh* NextPart(const ColoredMesh& mesh, size_t begin, size_t max_vertices, bool linear,
                 std::vector<int>* local, size_t* end) {
  std::vector<int> used;  // the part's vertices, by their number in `mesh`
  size_t f = begin;
  for (; f < mesh.faces.size(); ++f) {
    size_t fresh = 0;
    for (const int v : mesh.faces[f]) fresh += (*local)[static_cast<size_t>(v)] < 0;
    if (f > begin && used.size() + fresh > max_vertices) break;
    for (const int v : mesh.faces[f]) {
      int& number = (*local)[static_cast<size_t>(v)];
      if (number >= 0) continue;
      number = static_cast<int>(used.size());
      used.push_back(v);
    }
  }
  *end = f;
  auto* out = new aiMesh();
  out->mMaterialIndex = 0;
  out->mPrimitiveTypes = aiPrimitiveType_TRIANGLE;
  out->mNumVertices = static_cast<unsigned>(used.size());
  out->mVertices = new aiVector3D[used.size()];
  out->mColors[0] = new aiColor4D[used.size()];
  // glTF's COLOR_0 is linear (glTF 2.0, "Meshes"); OBJ and PLY viewers show colours as stored.
  for (size_t i = 0; i < used.size(); ++i) {
    const auto v = static_cast<size_t>(used[i]);
    const Eigen::Vector3f& p = mesh.vertices[v];
    const Eigen::Vector3f c = linear ? LinearFromSrgb(mesh.colors[v]) : mesh.colors[v];
    out->mVertices[i] = aiVector3D(p.x(), p.y(), p.z());
    out->mColors[0][i] = aiColor4D(c.x(), c.y(), c.z(), 1.0f);
  }
  out->mNumFaces = static_cast<unsigned>(f - begin);
  out->mFaces = new aiFace[out->mNumFaces];
  for (size_t k = begin; k < f; ++k) {
    aiFace& face = out->mFaces[k - begin];
    face.mNumIndices = 3;
    face.mIndices = new unsigned[3];
    for (int c = 0; c < 3; ++c) {
      face.mIndices[c] = static_cast<unsigned>((*local)[static_cast<size_t>(mesh.faces[k][c])]);
    }
  }
  for (const int v : used) (*local)[static_cast<size_t>(v)] = -1;
  return out;
}

}  // namespace

void MapMeshOptions::Validate() const {
  if (format != "glb" && format != "obj" && format != "ply") {
    throw InputError(fmt::format("{}: '", OptionKey(*this, format)) + format +
                     "' is not one of glb, obj, ply");
  }
  if (!(voxel >= 0.005 && voxel <= 1.0))
    throw InputError(fmt::format("{} must be in [0.005, 1] m", OptionKey(*this, voxel)));
  if (min_points < 1)
    throw InputError(fmt::format("{} must be at least 1", OptionKey(*this, min_points)));
}

ColoredMesh VoxelSurfaceMesh(const std::vector<VoxelPoint>& points, const MapMeshOptions& options) {
  options.Validate();
  const float edge = static_cast<float>(options.voxel);
  std::unordered_map<std::int64_t, Cell> cells;
  std::unordered_map<std::int64_t, Eigen::Vector3i> index;
  cells.reserve(points.size() / 4);
  for (const VoxelPoint& point : points) {
    const Eigen::Vector3i v = (point.position / edge).array().floor().cast<int>();
    const std::int64_t key = VoxelKey(v.x(), v.y(), v.z());
    Cell& cell = cells[key];
    if (cell.points == 0) index.emplace(key, v);
    cell.color_sum +=
        Eigen::Vector3f(point.rgb[0], point.rgb[1], point.rgb[2]) * static_cast<float>(point.count);
    cell.points += point.count;
  }
  auto occupied = [&](int x, int y, int z) {
    const auto it = cells.find(VoxelKey(x, y, z));
    return it != cells.end() && it->second.points >= static_cast<std::uint32_t>(options.min_points);
  };
  // The six faces: outward normal axis and sign, and the four corners (unit cube), ordered
  // counter-clockwise seen from outside.
  struct Face {
    Eigen::Vector3i normal;
    std::array<Eigen::Vector3f, 4> corners;
  };
  using V = Eigen::Vector3f;
  const std::array<Face, 6> faces = {{
      {{1, 0, 0}, {V(1, 0, 0), V(1, 1, 0), V(1, 1, 1), V(1, 0, 1)}},
      {{-1, 0, 0}, {V(0, 0, 0), V(0, 0, 1), V(0, 1, 1), V(0, 1, 0)}},
      {{0, 1, 0}, {V(0, 1, 0), V(0, 1, 1), V(1, 1, 1), V(1, 1, 0)}},
      {{0, -1, 0}, {V(0, 0, 0), V(1, 0, 0), V(1, 0, 1), V(0, 0, 1)}},
      {{0, 0, 1}, {V(0, 0, 1), V(1, 0, 1), V(1, 1, 1), V(0, 1, 1)}},
      {{0, 0, -1}, {V(0, 0, 0), V(0, 1, 0), V(1, 1, 0), V(1, 0, 0)}},
  }};
  ColoredMesh mesh;
  // Faces share their corners: one vertex per lattice corner on the surface, colored with the
  // mean of the voxels whose faces meet there. Bonn: 102 k vertices instead of 414 k (four per
  // face), mesh 0.61 -> 0.45 s; the .glb stays 5.3 MB (assimp's exporter already joined
  // identical vertices; the indices are half of it).
  std::unordered_map<std::int64_t, int> corner_vertex;
  std::vector<int> corner_faces;
  auto vertex_at = [&](const Eigen::Vector3i& corner, const Eigen::Vector3f& color) {
    const auto [it, added] = corner_vertex.emplace(VoxelKey(corner.x(), corner.y(), corner.z()),
                                                   static_cast<int>(mesh.vertices.size()));
    if (added) {
      mesh.vertices.push_back(corner.cast<float>() * edge);
      mesh.colors.push_back(Eigen::Vector3f::Zero());
      corner_faces.push_back(0);
    }
    const auto vertex = static_cast<size_t>(it->second);
    mesh.colors[vertex] += color;
    ++corner_faces[vertex];
    return it->second;
  };
  for (const auto& [key, cell] : cells) {
    if (cell.points < static_cast<std::uint32_t>(options.min_points)) continue;
    const Eigen::Vector3i& v = index.at(key);
    const Eigen::Vector3f color = cell.color_sum / (255.0f * static_cast<float>(cell.points));
    ++mesh.voxels;
    for (const Face& face : faces) {
      if (occupied(v.x() + face.normal.x(), v.y() + face.normal.y(), v.z() + face.normal.z())) {
        continue;
      }
      std::array<int, 4> corner{};
      for (size_t c = 0; c < 4; ++c) corner[c] = vertex_at(v + face.corners[c].cast<int>(), color);
      mesh.faces.push_back({corner[0], corner[1], corner[2]});
      mesh.faces.push_back({corner[0], corner[2], corner[3]});
    }
  }
  for (size_t i = 0; i < mesh.colors.size(); ++i) {
    mesh.colors[i] /= static_cast<float>(corner_faces[i]);
  }
  return mesh;
}

Eigen::Vector3f LinearFromSrgb(const Eigen::Vector3f& srgb) {
  auto channel = [](float c) {  // IEC 61966-2-1
    return c <= 0.04045f ? c / 12.92f : std::pow((c + 0.055f) / 1.055f, 2.4f);
  };
  return {channel(srgb.x()), channel(srgb.y()), channel(srgb.z())};
}

void WriteColoredMesh(const std::string& path, const ColoredMesh& mesh, const std::string& format,
                      size_t glb_part_vertices) {
  // Refused, not exported: with no vertices, assimp's scene copy (SceneCombiner::Copy, which the
  // exporter always makes) copies only the colour sets it thinks present (HasVertexColors() needs
  // mNumVertices > 0), so the copy would share this scene's colour array and both scenes would
  // delete it (ASan: double free in aiScene::~aiScene). An empty mesh is the caller's result to
  // report.
  if (mesh.faces.empty() || mesh.vertices.empty() || mesh.colors.size() != mesh.vertices.size()) {
    throw std::invalid_argument(path + ": cannot write a mesh without faces");
  }
  // The parts under the root node. Every array below is allocated with new[] (objects with new)
  // because the scene's destructors free them with delete[] (delete): the scene owns them, and
  // none is empty (see above).
  const bool linear = format == "glb";
  std::vector<std::unique_ptr<aiMesh>> parts;
  std::vector<int> local(mesh.vertices.size(), -1);
  const size_t part_vertices = format == "glb" ? std::max<size_t>(3, glb_part_vertices) : SIZE_MAX;
  for (size_t begin = 0; begin < mesh.faces.size();) {
    parts.emplace_back(NextPart(mesh, begin, part_vertices, linear, &local, &begin));
  }
  aiScene scene;
  scene.mRootNode = new aiNode();
  scene.mMaterials = new aiMaterial*[1];
  scene.mMaterials[0] = new aiMaterial();
  scene.mNumMaterials = 1;
  scene.mNumMeshes = static_cast<unsigned>(parts.size());
  scene.mMeshes = new aiMesh*[parts.size()];
  scene.mRootNode->mNumMeshes = scene.mNumMeshes;
  scene.mRootNode->mMeshes = new unsigned[parts.size()];
  for (unsigned m = 0; m < scene.mNumMeshes; ++m) {
    scene.mMeshes[m] = parts[m].release();
    scene.mRootNode->mMeshes[m] = m;
  }
  // glTF is y up (glTF 2.0, "Coordinate System and Units"): the root node turns the map frame's
  // z up into it, so glTF viewers and Blender's importer show the room upright; the vertices
  // keep the map frame's coordinates. OBJ and PLY have no convention: they hold the map frame.
  if (format == "glb") scene.mRootNode->mTransformation = GltfFromMap();

  const char* id = format == "glb" ? "glb2" : format == "obj" ? "obj" : "ply";
  Assimp::Exporter exporter;
  if (exporter.Export(&scene, id, path) != AI_SUCCESS) {
    throw std::runtime_error(path + ": could not write the mesh (" + exporter.GetErrorString() +
                             ")");
  }
}

}  // namespace stillmap
