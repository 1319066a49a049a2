// Point cloud files (PLY, PCD) through PCL, so that PCL, Open3D, MeshLab and CloudCompare read
// them.
#pragma once

#include <string>
#include <vector>

#include "stillmap/mapping/voxel_cloud.h"

namespace stillmap {

// Binary little-endian PLY with float x, y, z and uchar red, green, blue per vertex.
void WritePly(const std::string& path, const std::vector<VoxelPoint>& points);

// Binary PCD with fields x y z rgb (PCL's packed PointXYZRGB).
void WritePcd(const std::string& path, const std::vector<VoxelPoint>& points);

// Reads the vertices (and colors, when present) of a PLY or PCD file; count is set to 1. Throws
// InputError when the file cannot be read.
std::vector<VoxelPoint> ReadCloud(const std::string& path);

}  // namespace stillmap
