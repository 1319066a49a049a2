#include "stillmap/mapping/map_io.h"

#include <pcl/io/pcd_io.h>
#include <pcl/io/ply_io.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <stdexcept>

#include "stillmap/io/error.h"

namespace stillmap {
namespace {

pcl::PointCloud<pcl::PointXYZRGB> ToPcl(const std::vector<VoxelPoint>& points) {
  pcl::PointCloud<pcl::PointXYZRGB> cloud;
  cloud.resize(points.size());
  for (size_t i = 0; i < points.size(); ++i) {
    pcl::PointXYZRGB& p = cloud[i];
    p.x = points[i].position.x();
    p.y = points[i].position.y();
    p.z = points[i].position.z();
    p.r = points[i].rgb[0];
    p.g = points[i].rgb[1];
    p.b = points[i].rgb[2];
  }
  cloud.width = static_cast<std::uint32_t>(points.size());
  cloud.height = 1;
  cloud.is_dense = true;
  return cloud;
}

}  // namespace

void WritePly(const std::string& path, const std::vector<VoxelPoint>& points) {
  // No PCL "camera" element: plain vertex lists open everywhere (Open3D, MeshLab, CloudCompare).
  pcl::PLYWriter writer;
  if (writer.write(path, ToPcl(points), /*binary=*/true, /*use_camera=*/false) != 0) {
    throw std::runtime_error(path + ": could not write the PLY cloud");
  }
}

void WritePcd(const std::string& path, const std::vector<VoxelPoint>& points) {
  if (pcl::io::savePCDFileBinary(path, ToPcl(points)) != 0) {
    throw std::runtime_error(path + ": could not write the PCD cloud");
  }
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
