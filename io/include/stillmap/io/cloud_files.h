// Point cloud files (PLY, PCD) through PCL, so that PCL, Open3D, MeshLab and CloudCompare read
// them.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace stillmap {

// A colored point of a map: the centroid of a voxel's points with their mean color.
struct VoxelPoint {
  Eigen::Vector3f position;         // centroid of the voxel's points [m]
  std::array<std::uint8_t, 3> rgb;  // mean color
  std::uint32_t count;              // points averaged
};

// Writes a voxel cloud's points (VoxelCloud::Points), in one streaming pass, as a binary
// little-endian PLY (float x, y, z; uchar red, green, blue per vertex) and a binary PCD (fields
// x y z rgb, PCL's packed PointXYZRGB: rgb a float field holding 0x00RRGGBB). Written here rather
// than with PCL's writers, which need the whole cloud copied into a pcl::PointCloud first: on Bonn
// (6.1 M voxels) that copy and ours cost 340 MB of peak memory. PCL reads both files back in the
// tests. `frame` names the points' frame in the headers' comments (PLY: "comment frame: ...",
// PCD: "# frame: ...").
void WriteCloudFiles(const std::string& ply_path, const std::string& pcd_path,
                     const std::vector<VoxelPoint>& points, double leaf_size,
                     const std::string& frame);

// Writes points as a binary little-endian PLY (float x, y, z; uchar red, green, blue).
void WritePly(const std::string& path, const std::vector<VoxelPoint>& points);

// Reads the vertices (and colors, when present) of a PLY or PCD file; count is set to 1. Throws
// InputError when the file cannot be read.
std::vector<VoxelPoint> ReadCloud(const std::string& path);

}  // namespace stillmap
