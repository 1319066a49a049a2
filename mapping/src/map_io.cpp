#include "stillmap/mapping/map_io.h"

#include <pcl/io/pcd_io.h>
#include <pcl/io/ply_io.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <cstdint>
#include <fstream>
#include <stdexcept>

#include "stillmap/io/error.h"

namespace stillmap {
void WriteCloudFiles(const std::string& ply_path, const std::string& pcd_path,
                     const VoxelCloud& cloud) {
  static_assert(sizeof(float) == 4, "PLY and PCD floats are 4 bytes");
  static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__, "records are copied as little-endian");
  std::ofstream ply(ply_path, std::ios::binary);
  std::ofstream pcd(pcd_path, std::ios::binary);
  if (!ply) throw std::runtime_error(ply_path + ": cannot write the PLY cloud");
  if (!pcd) throw std::runtime_error(pcd_path + ": cannot write the PCD cloud");
  const size_t n = cloud.size();
  ply << "ply\nformat binary_little_endian 1.0\ncomment stillmap voxel cloud, leaf "
      << cloud.leaf_size() << " m\nelement vertex " << n
      << "\nproperty float x\nproperty float y\nproperty float z\nproperty uchar red\n"
         "property uchar green\nproperty uchar blue\nend_header\n";
  pcd << "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS x y z rgb\n"
         "SIZE 4 4 4 4\nTYPE F F F U\nCOUNT 1 1 1 1\nWIDTH "
      << n << "\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS " << n << "\nDATA binary\n";
  // Records are assembled in buffers and written in blocks (the x86-64 / ARM byte order is the
  // little-endian order both formats use here).
  constexpr size_t kBlock = 1 << 16;
  std::vector<char> ply_buffer, pcd_buffer;
  ply_buffer.reserve(kBlock * 15);
  pcd_buffer.reserve(kBlock * 16);
  auto flush = [&] {
    ply.write(ply_buffer.data(), static_cast<std::streamsize>(ply_buffer.size()));
    pcd.write(pcd_buffer.data(), static_cast<std::streamsize>(pcd_buffer.size()));
    ply_buffer.clear();
    pcd_buffer.clear();
  };
  cloud.ForEachPoint([&](const VoxelPoint& p) {
    const char* xyz = reinterpret_cast<const char*>(p.position.data());
    ply_buffer.insert(ply_buffer.end(), xyz, xyz + 12);
    ply_buffer.insert(ply_buffer.end(), p.rgb.begin(), p.rgb.end());
    const std::uint32_t rgb =
        (std::uint32_t{p.rgb[0]} << 16) | (std::uint32_t{p.rgb[1]} << 8) | std::uint32_t{p.rgb[2]};
    pcd_buffer.insert(pcd_buffer.end(), xyz, xyz + 12);
    const char* packed = reinterpret_cast<const char*>(&rgb);
    pcd_buffer.insert(pcd_buffer.end(), packed, packed + 4);
    if (ply_buffer.size() >= kBlock * 15) flush();
  });
  flush();
  if (!ply.flush()) throw std::runtime_error(ply_path + ": could not write the PLY cloud");
  if (!pcd.flush()) throw std::runtime_error(pcd_path + ": could not write the PCD cloud");
}

std::vector<VoxelPoint> ReadCloud(const std::string& path) {
  pcl::PointCloud<pcl::PointXYZRGB> cloud;
  const bool is_pcd = path.size() >= 4 && path.compare(path.size() - 4, 4, ".pcd") == 0;
  const int status = is_pcd ? pcl::io::loadPCDFile(path, cloud) : pcl::io::loadPLYFile(path, cloud);
  if (status != 0) throw InputError(path + ": could not read the point cloud");
  std::vector<VoxelPoint> points(cloud.size());
  for (size_t i = 0; i < cloud.size(); ++i) {
    points[i].position = cloud[i].getVector3fMap();
    points[i].rgb = {cloud[i].r, cloud[i].g, cloud[i].b};
    points[i].count = 1;
  }
  return points;
}

}  // namespace stillmap
