// The map mesh against exact counts: the exposed faces of known voxel sets, and the file read back
// through assimp in each format.
#include "stillmap/mapping/map_mesh.h"

#include <assimp/postprocess.h>
#include <assimp/scene.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <assimp/Importer.hpp>
#include <cmath>
#include <filesystem>

#include "stillmap/io/error.h"
#include "stillmap/synth/mesh.h"
#include "test_util.h"

namespace stillmap {
namespace {

// One map point at the centre of each voxel (i, j, k) of `edge`, each standing for `count` points.
std::vector<VoxelPoint> Block(int nx, int ny, int nz, float edge, std::uint32_t count = 5) {
  std::vector<VoxelPoint> points;
  for (int i = 0; i < nx; ++i) {
    for (int j = 0; j < ny; ++j) {
      for (int k = 0; k < nz; ++k) {
        VoxelPoint p;
        p.position = Eigen::Vector3f(i + 0.5f, j + 0.5f, k + 0.5f) * edge;
        p.rgb = {200, 100, 50};
        p.count = count;
        points.push_back(p);
      }
    }
  }
  return points;
}

TEST(MapMeshTest, ExposedFacesOfKnownBlocks) {
  MapMeshOptions options;
  options.voxel = 0.1;
  // A single voxel: 6 faces, 12 triangles; a 3x3x3 block: 6 sides of 9 faces, hidden faces none.
  ColoredMesh one = VoxelSurfaceMesh(Block(1, 1, 1, 0.1f), options);
  EXPECT_EQ(one.voxels, 1u);
  EXPECT_EQ(one.faces.size(), 12u);
  EXPECT_EQ(one.vertices.size(), 8u);  // the cube's corners, shared by its faces
  ColoredMesh block = VoxelSurfaceMesh(Block(3, 3, 3, 0.1f), options);
  EXPECT_EQ(block.voxels, 27u);
  EXPECT_EQ(block.faces.size(), 6u * 9u * 2u);
  EXPECT_EQ(block.vertices.size(), 4u * 4u * 4u - 2u * 2u * 2u);  // lattice corners on the surface
  // Its surface area is the cube's (0.3 m edge), and every face points outward: the signed
  // volume (divergence theorem) is the cube's.
  double area = 0.0, volume = 0.0;
  for (const auto& f : block.faces) {
    const Eigen::Vector3d a = block.vertices[static_cast<size_t>(f[0])].cast<double>();
    const Eigen::Vector3d b = block.vertices[static_cast<size_t>(f[1])].cast<double>();
    const Eigen::Vector3d c = block.vertices[static_cast<size_t>(f[2])].cast<double>();
    area += 0.5 * (b - a).cross(c - a).norm();
    volume += a.dot(b.cross(c)) / 6.0;
  }
  EXPECT_NEAR(area, 6 * 0.09, 1e-6);
  EXPECT_NEAR(volume, 0.027, 1e-6);
  for (const Eigen::Vector3f& color : block.colors) {
    EXPECT_NEAR(color.x(), 200.0f / 255.0f, 1e-6f);
    EXPECT_NEAR(color.z(), 50.0f / 255.0f, 1e-6f);
  }
  // Voxels with fewer map points than min_points are left out.
  options.min_points = 6;
  EXPECT_EQ(VoxelSurfaceMesh(Block(3, 3, 3, 0.1f, 5), options).voxels, 0u);
}

TEST(MapMeshTest, EachFormatReadsBackThroughAssimp) {
  MapMeshOptions options;
  options.voxel = 0.1;
  const ColoredMesh mesh = VoxelSurfaceMesh(Block(4, 2, 3, 0.1f), options);
  testing::TempDir dir;
  for (const std::string format : {"glb", "obj", "ply"}) {
    const std::string path = dir / ("mesh." + format);
    WriteColoredMesh(path, mesh, format);
    const TriangleMesh back = LoadMesh(path);
    EXPECT_EQ(back.faces.size(), mesh.faces.size()) << format;
    Eigen::AlignedBox3f box;
    for (const Eigen::Vector3f& v : back.vertices) box.extend(v);
    EXPECT_TRUE(box.min().isZero(1e-5f)) << format << ": " << box.min().transpose();
    EXPECT_TRUE(box.max().isApprox(Eigen::Vector3f(0.4f, 0.2f, 0.3f), 1e-5f))
        << format << ": " << box.max().transpose();
    EXPECT_NEAR(back.Area(), 2 * (0.4 * 0.2 + 0.4 * 0.3 + 0.2 * 0.3), 1e-5) << format;
  }
  options.format = "stl";
  EXPECT_THROW(options.Validate(), InputError);
}

// The first vertex colour of the file's first mesh, read by assimp.
Eigen::Vector3f FirstColor(const std::string& path) {
  Assimp::Importer importer;
  const aiScene* scene = importer.ReadFile(path, aiProcess_Triangulate);
  if (scene == nullptr || scene->mNumMeshes == 0 || !scene->mMeshes[0]->HasVertexColors(0)) {
    ADD_FAILURE() << path << ": no vertex colours read back";
    return Eigen::Vector3f::Constant(-1.0f);
  }
  const aiColor4D& c = scene->mMeshes[0]->mColors[0][0];
  return {c.r, c.g, c.b};
}

// glTF vertex colours are linear: the map's sRGB (200, 100, 50) is stored as IEC 61966-2-1's
// linear values (0.5776, 0.1274, 0.0319); PLY keeps the colours as the camera gave them.
TEST(MapMeshTest, GltfColoursAreLinearPlyColoursAsCaptured) {
  MapMeshOptions options;
  options.voxel = 0.1;
  const ColoredMesh mesh = VoxelSurfaceMesh(Block(1, 1, 1, 0.1f), options);
  testing::TempDir dir;
  WriteColoredMesh(dir / "mesh.glb", mesh, "glb");
  EXPECT_TRUE(
      FirstColor(dir / "mesh.glb").isApprox(Eigen::Vector3f(0.5776f, 0.1274f, 0.0319f), 1e-3f))
      << FirstColor(dir / "mesh.glb").transpose();
  WriteColoredMesh(dir / "mesh.ply", mesh, "ply");
  EXPECT_TRUE(FirstColor(dir / "mesh.ply").isApprox(Eigen::Vector3f(200, 100, 50) / 255.0f, 1e-3f))
      << FirstColor(dir / "mesh.ply").transpose();
  // The conversion's ends and its linear segment.
  EXPECT_TRUE(LinearFromSrgb(Eigen::Vector3f(0, 1, 0.04f))
                  .isApprox(Eigen::Vector3f(0, 1, 0.04f / 12.92f), 1e-6f));
}

// glTF is y up: read as glTF viewers and Blender place it (the root node applied), the block
// that stands 0.3 m tall along the map's z stands 0.3 m tall along glTF's y, and the map's y
// (0.2 m deep) runs along glTF's -z. OBJ keeps the map frame's coordinates as they are.
TEST(MapMeshTest, GltfStandsUpOnItsYAxis) {
  MapMeshOptions options;
  options.voxel = 0.1;
  const ColoredMesh mesh = VoxelSurfaceMesh(Block(4, 2, 3, 0.1f), options);
  testing::TempDir dir;
  for (const std::string format : {"glb", "obj"}) {
    const std::string path = dir / ("mesh." + format);
    WriteColoredMesh(path, mesh, format);
    Assimp::Importer importer;
    const aiScene* scene = importer.ReadFile(path, aiProcess_PreTransformVertices);
    ASSERT_TRUE(scene != nullptr && scene->mNumMeshes == 1) << path;
    Eigen::AlignedBox3f box;
    const aiMesh* read = scene->mMeshes[0];
    for (unsigned i = 0; i < read->mNumVertices; ++i) {
      box.extend(Eigen::Vector3f(read->mVertices[i].x, read->mVertices[i].y, read->mVertices[i].z));
    }
    const Eigen::Vector3f min =
        format == "glb" ? Eigen::Vector3f(0, 0, -0.2f) : Eigen::Vector3f(0, 0, 0);
    const Eigen::Vector3f max =
        format == "glb" ? Eigen::Vector3f(0.4f, 0.3f, 0) : Eigen::Vector3f(0.4f, 0.2f, 0.3f);
    EXPECT_TRUE((box.min() - min).norm() < 1e-5f) << format << ": " << box.min().transpose();
    EXPECT_TRUE((box.max() - max).norm() < 1e-5f) << format << ": " << box.max().transpose();
  }
}

// Each face read back from a glb as its three corners (position and colour, rounded to 1e-4),
// rotated to start at the smallest so that the winding stays; sorted.
std::vector<std::array<std::array<long, 6>, 3>> GlbFaces(const std::string& path, unsigned* meshes,
                                                         unsigned* largest_vertices) {
  Assimp::Importer importer;
  const aiScene* scene = importer.ReadFile(path, 0);
  std::vector<std::array<std::array<long, 6>, 3>> faces;
  if (scene == nullptr) return faces;
  *meshes = scene->mNumMeshes;
  *largest_vertices = 0;
  for (unsigned m = 0; m < scene->mNumMeshes; ++m) {
    const aiMesh* read = scene->mMeshes[m];
    *largest_vertices = std::max(*largest_vertices, read->mNumVertices);
    for (unsigned f = 0; f < read->mNumFaces; ++f) {
      std::array<std::array<long, 6>, 3> face{};
      for (unsigned c = 0; c < 3; ++c) {
        const unsigned v = read->mFaces[f].mIndices[c];
        const aiVector3D& p = read->mVertices[v];
        const aiColor4D& k = read->mColors[0][v];
        for (int d = 0; d < 6; ++d) {
          const float value = d < 3 ? p[static_cast<unsigned>(d)] : (&k.r)[d - 3];
          face[c][static_cast<size_t>(d)] = std::lround(value * 1e4f);
        }
      }
      std::rotate(face.begin(), std::min_element(face.begin(), face.end()), face.end());
      faces.push_back(face);
    }
  }
  std::sort(faces.begin(), faces.end());
  return faces;
}

// A glb written in parts of at most 40 vertices holds the same triangles, with the same corner
// colours and winding, as the one written whole, and no part has more vertices.
TEST(MapMeshTest, AGlbInPartsHoldsTheSameTriangles) {
  MapMeshOptions options;
  options.voxel = 0.1;
  ColoredMesh mesh = VoxelSurfaceMesh(Block(5, 4, 3, 0.1f), options);
  for (size_t i = 0; i < mesh.colors.size(); ++i) {  // a colour of its own for every vertex
    mesh.colors[i] = Eigen::Vector3f(i % 7, i % 11, i % 13)
                         .cwiseProduct(Eigen::Vector3f(1.0f / 7.0f, 1.0f / 11.0f, 1.0f / 13.0f));
  }
  testing::TempDir dir;
  const std::string whole = dir / "whole.glb", parts = dir / "parts.glb";
  WriteColoredMesh(whole, mesh, "glb");
  WriteColoredMesh(parts, mesh, "glb", 40);
  unsigned whole_meshes = 0, parts_meshes = 0, whole_largest = 0, parts_largest = 0;
  const auto a = GlbFaces(whole, &whole_meshes, &whole_largest);
  const auto b = GlbFaces(parts, &parts_meshes, &parts_largest);
  EXPECT_EQ(whole_meshes, 1u);
  EXPECT_EQ(whole_largest, mesh.vertices.size());
  EXPECT_GE(parts_meshes, mesh.vertices.size() / 40);
  EXPECT_LE(parts_largest, 40u);
  ASSERT_EQ(a.size(), mesh.faces.size());
  EXPECT_TRUE(a == b);
}

// assimp cannot export a mesh without faces (its exporter frees the scene's copy twice): the
// writer refuses it before assimp sees it.
TEST(MapMeshTest, AnEmptyMeshIsRefusedNotExported) {
  testing::TempDir dir;
  const ColoredMesh empty = VoxelSurfaceMesh({}, MapMeshOptions());
  EXPECT_TRUE(empty.faces.empty());
  for (const std::string format : {"glb", "obj", "ply"}) {
    EXPECT_THROW(WriteColoredMesh(dir / ("empty." + format), empty, format), std::invalid_argument);
    EXPECT_FALSE(std::filesystem::exists(dir / ("empty." + format)));
  }
}
}  // namespace
}  // namespace stillmap
