// Triangle meshes with texture coordinates: built from primitives, written as OBJ and read back
// through assimp (so any OBJ/PLY/glTF a user supplies loads the same way).
#pragma once

#include <Eigen/Geometry>
#include <array>
#include <string>
#include <vector>

namespace stillmap {

struct TriangleMesh {
  std::vector<Eigen::Vector3f> vertices;  // [m], in the mesh's own frame
  std::vector<Eigen::Vector2f> uvs;       // one per vertex; texture space, repeats outside [0,1]
  std::vector<std::array<int, 3>> faces;  // counter-clockwise seen from outside

  // Appends `other` transformed by `this_from_other`.
  void Append(const TriangleMesh& other,
              const Eigen::Isometry3f& this_from_other = Eigen::Isometry3f::Identity());
  // Total surface area [m^2].
  double Area() const;
};

// An axis-aligned box centred at `center` with edge lengths `size`, faces pointing outward (or
// inward, for a room seen from inside). Texture coordinates are metres along each face divided by
// `texture_tile` (one texture repeat per tile).
TriangleMesh MakeBox(const Eigen::Vector3f& center, const Eigen::Vector3f& size,
                     float texture_tile = 1.0f, bool inward = false);

// A quad from corner `origin` spanned by `u_edge` and `v_edge`, texture [0,1]^2 over it (for
// posters and screens), facing u_edge x v_edge.
TriangleMesh MakeQuad(const Eigen::Vector3f& origin, const Eigen::Vector3f& u_edge,
                      const Eigen::Vector3f& v_edge);

// A surface of revolution about the z axis: at height z(t) the cross-section is an ellipse with
// half-axes (rx(t), ry(t)) for t in [0, 1] sampled `rings` + 1 times, `segments` around. Texture
// u runs around (from +y), v along t. Used for limbs, torsos and heads.
TriangleMesh MakeRevolved(const std::vector<Eigen::Vector3f>& profile_z_rx_ry, int segments);

// A capsule along -z from the origin: a cylinder of `radius` and `length` with rounded ends.
TriangleMesh MakeCapsule(float radius, float length, int segments = 14);

// An ellipsoid centred at the origin with half-axes `radii`.
TriangleMesh MakeEllipsoid(const Eigen::Vector3f& radii, int segments = 16);

// Writes a Wavefront OBJ (v, vt, f with v/vt). Throws std::runtime_error when it cannot write.
void WriteObj(const std::string& path, const TriangleMesh& mesh);

// Reads every mesh of a file assimp understands (OBJ, PLY, glTF...) into one triangulated mesh,
// keeping the first UV channel. Throws InputError naming the file and assimp's message.
TriangleMesh LoadMesh(const std::string& path);

}  // namespace stillmap
