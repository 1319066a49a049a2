// Point cloud files (PLY, PCD) through PCL, so that PCL, Open3D, MeshLab and CloudCompare read
// them.
#pragma once

#include <string>
#include <vector>

#include "stillmap/mapping/voxel_cloud.h"

namespace stillmap {

// Writes the voxel cloud, in one streaming pass, as a binary little-endian PLY (float x, y, z;
// uchar red, green, blue per vertex) and a binary PCD (fields x y z rgb, PCL's packed
// PointXYZRGB). Written here rather than with PCL's writers, which need the whole cloud copied
// into a pcl::PointCloud first: on Bonn (6.1 M voxels) that copy and ours cost 340 MB of peak
// memory. PCL reads both files back in the tests.
void WriteCloudFiles(const std::string& ply_path, const std::string& pcd_path,
                     const VoxelCloud& cloud);

// The same two files from points already taken out of the cloud (VoxelCloud::Points): the
// pipeline needs them anyway, and this saves a second sort of the table.
void WriteCloudFiles(const std::string& ply_path, const std::string& pcd_path,
                     const std::vector<VoxelPoint>& points, double leaf_size);

// Writes points as a binary little-endian PLY (float x, y, z; uchar red, green, blue).
void WritePly(const std::string& path, const std::vector<VoxelPoint>& points);

// Reads the vertices (and colors, when present) of a PLY or PCD file; count is set to 1. Throws
// InputError when the file cannot be read.
std::vector<VoxelPoint> ReadCloud(const std::string& path);

}  // namespace stillmap
