#include "stillmap/synth/mesh.h"

#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include <assimp/Importer.hpp>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <stdexcept>

#include "stillmap/io/error.h"

namespace stillmap {

void TriangleMesh::Append(const TriangleMesh& other, const Eigen::Isometry3f& this_from_other) {
  const int offset = static_cast<int>(vertices.size());
  for (const Eigen::Vector3f& v : other.vertices) vertices.push_back(this_from_other * v);
  uvs.insert(uvs.end(), other.uvs.begin(), other.uvs.end());
  for (const auto& f : other.faces) faces.push_back({f[0] + offset, f[1] + offset, f[2] + offset});
}

double TriangleMesh::Area() const {
  double area = 0.0;
  for (const auto& f : faces) {
    area += 0.5 * (vertices[f[1]] - vertices[f[0]]).cross(vertices[f[2]] - vertices[f[0]]).norm();
  }
  return area;
}

TriangleMesh MakeQuad(const Eigen::Vector3f& origin, const Eigen::Vector3f& u_edge,
                      const Eigen::Vector3f& v_edge) {
  TriangleMesh quad;
  quad.vertices = {origin, origin + u_edge, origin + u_edge + v_edge, origin + v_edge};
  quad.uvs = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
  quad.faces = {{0, 1, 2}, {0, 2, 3}};
  return quad;
}

TriangleMesh MakeBox(const Eigen::Vector3f& center, const Eigen::Vector3f& size, float texture_tile,
                     bool inward) {
  TriangleMesh box;
  const Eigen::Vector3f h = 0.5f * size;
  // Each face: the outward normal axis and sign, and two in-plane axes (right-handed with it).
  for (int axis = 0; axis < 3; ++axis) {
    for (int sign : {-1, 1}) {
      const int a = (axis + 1) % 3, b = (axis + 2) % 3;
      Eigen::Vector3f u_edge = Eigen::Vector3f::Zero(), v_edge = Eigen::Vector3f::Zero();
      u_edge[a] = size[a];
      v_edge[b] = size[b];
      Eigen::Vector3f origin = center - h;
      origin[axis] = center[axis] + sign * h[axis];
      // u x v points along +axis; flip winding for the -axis face (and for inward boxes).
      const bool flip = (sign < 0) != inward;
      TriangleMesh quad =
          flip ? MakeQuad(origin, v_edge, u_edge) : MakeQuad(origin, u_edge, v_edge);
      const float su = (flip ? size[b] : size[a]) / texture_tile;
      const float sv = (flip ? size[a] : size[b]) / texture_tile;
      for (Eigen::Vector2f& uv : quad.uvs) uv = Eigen::Vector2f(uv.x() * su, uv.y() * sv);
      box.Append(quad);
    }
  }
  return box;
}

TriangleMesh MakeRevolved(const std::vector<Eigen::Vector3f>& profile, int segments) {
  TriangleMesh mesh;
  const int rings = static_cast<int>(profile.size()) - 1;
  for (int r = 0; r <= rings; ++r) {
    for (int s = 0; s <= segments; ++s) {
      const float angle = 2.0f * 3.14159265f * static_cast<float>(s) / static_cast<float>(segments);
      const Eigen::Vector3f& p = profile[static_cast<size_t>(r)];
      mesh.vertices.emplace_back(p[1] * std::sin(angle), p[2] * std::cos(angle), p[0]);
      mesh.uvs.emplace_back(static_cast<float>(s) / static_cast<float>(segments),
                            static_cast<float>(r) / static_cast<float>(rings));
    }
  }
  const int row = segments + 1;
  for (int r = 0; r < rings; ++r) {
    for (int s = 0; s < segments; ++s) {
      const int a = r * row + s, b = a + 1, c = a + row, d = c + 1;
      mesh.faces.push_back({a, b, c});  // outward for a profile listed from top to bottom
      mesh.faces.push_back({b, d, c});
    }
  }
  return mesh;
}

TriangleMesh MakeCapsule(float radius, float length, int segments) {
  // Profile from the top cap (z = 0) down to the bottom cap (z = -length).
  std::vector<Eigen::Vector3f> profile;
  const int cap_rings = 4;
  for (int i = 0; i <= cap_rings; ++i) {
    const float a = 1.5707963f * static_cast<float>(i) / cap_rings;  // 0 .. 90 deg
    const float r = radius * std::sin(a);
    profile.emplace_back(-radius * (1.0f - std::cos(a)), r, r);
  }
  for (int i = cap_rings; i >= 0; --i) {
    const float a = 1.5707963f * static_cast<float>(i) / cap_rings;
    const float r = radius * std::sin(a);
    profile.emplace_back(-length + radius * (1.0f - std::cos(a)), r, r);
  }
  return MakeRevolved(profile, segments);
}

TriangleMesh MakeEllipsoid(const Eigen::Vector3f& radii, int segments) {
  std::vector<Eigen::Vector3f> profile;
  const int rings = segments / 2;
  for (int i = 0; i <= rings; ++i) {
    const float a = 3.14159265f * static_cast<float>(i) / static_cast<float>(rings);  // top..bottom
    profile.emplace_back(radii.z() * std::cos(a), radii.x() * std::sin(a), radii.y() * std::sin(a));
  }
  return MakeRevolved(profile, segments);
}

void WriteObj(const std::string& path, const TriangleMesh& mesh) {
  std::ofstream out(path);
  if (!out) throw std::runtime_error(WriteFailure(path, "the mesh"));
  out << "# stillmap synthetic scene mesh\n";
  char line[160];
  for (const Eigen::Vector3f& v : mesh.vertices) {
    std::snprintf(line, sizeof(line), "v %.6f %.6f %.6f\n", v.x(), v.y(), v.z());
    out << line;
  }
  for (const Eigen::Vector2f& uv : mesh.uvs) {
    std::snprintf(line, sizeof(line), "vt %.6f %.6f\n", uv.x(), uv.y());
    out << line;
  }
  for (const auto& f : mesh.faces) {
    out << "f " << f[0] + 1 << "/" << f[0] + 1 << " " << f[1] + 1 << "/" << f[1] + 1 << " "
        << f[2] + 1 << "/" << f[2] + 1 << "\n";
  }
  if (!out.flush()) throw std::runtime_error(WriteFailure(path, "the mesh"));
}

TriangleMesh LoadMesh(const std::string& path) {
  Assimp::Importer importer;
  // No vertex joining: OBJ corners with different UVs must stay separate vertices.
  const aiScene* scene = importer.ReadFile(path, aiProcess_Triangulate);
  if (scene == nullptr || scene->mRootNode == nullptr) {
    throw InputError(path + ": cannot load the mesh (" + importer.GetErrorString() + ")");
  }
  TriangleMesh mesh;
  for (unsigned m = 0; m < scene->mNumMeshes; ++m) {
    const aiMesh* source = scene->mMeshes[m];
    const int offset = static_cast<int>(mesh.vertices.size());
    for (unsigned i = 0; i < source->mNumVertices; ++i) {
      const aiVector3D& v = source->mVertices[i];
      mesh.vertices.emplace_back(v.x, v.y, v.z);
      if (source->HasTextureCoords(0)) {
        mesh.uvs.emplace_back(source->mTextureCoords[0][i].x, source->mTextureCoords[0][i].y);
      } else {
        mesh.uvs.emplace_back(0.0f, 0.0f);
      }
    }
    for (unsigned f = 0; f < source->mNumFaces; ++f) {
      const aiFace& face = source->mFaces[f];
      if (face.mNumIndices != 3) continue;  // points and lines
      mesh.faces.push_back({offset + static_cast<int>(face.mIndices[0]),
                            offset + static_cast<int>(face.mIndices[1]),
                            offset + static_cast<int>(face.mIndices[2])});
    }
  }
  if (mesh.faces.empty()) throw InputError(path + ": the mesh has no triangles");
  return mesh;
}

}  // namespace stillmap
