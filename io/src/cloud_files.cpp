#include "stillmap/io/cloud_files.h"

#include <pcl/io/pcd_io.h>
#include <pcl/io/ply_io.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "stillmap/io/error.h"
#include "stillmap/io/input_files.h"

namespace stillmap {
namespace {

// Streams points into a PLY and/or a PCD file (empty path: not written). Records are assembled
// in blocks (the x86-64 / ARM byte order is the little-endian order both formats use here).
class CloudFileWriter {
 public:
  // `comments`: lines for the headers' comments.
  CloudFileWriter(const std::string& ply_path, const std::string& pcd_path, size_t count,
                  const std::vector<std::string>& comments)
      : ply_path_(ply_path), pcd_path_(pcd_path) {
    static_assert(sizeof(float) == 4, "PLY and PCD floats are 4 bytes");
    static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__, "records are copied as little-endian");
    if (!ply_path.empty()) {
      ply_.open(ply_path, std::ios::binary);
      if (!ply_) throw std::runtime_error(WriteFailure(ply_path, "the PLY cloud"));
      ply_ << "ply\nformat binary_little_endian 1.0\n";
      for (const std::string& line : comments) ply_ << "comment " << line << "\n";
      ply_ << "element vertex " << count
           << "\nproperty float x\nproperty float y\nproperty float z\nproperty uchar red\n"
              "property uchar green\nproperty uchar blue\nend_header\n";
    }
    if (!pcd_path.empty()) {
      pcd_.open(pcd_path, std::ios::binary);
      if (!pcd_) throw std::runtime_error(WriteFailure(pcd_path, "the PCD cloud"));
      pcd_ << "# .PCD v0.7 - Point Cloud Data file format\n";
      for (const std::string& line : comments) pcd_ << "# " << line << "\n";
      pcd_ << "VERSION 0.7\nFIELDS x y z rgb\n"
              "SIZE 4 4 4 4\nTYPE F F F F\nCOUNT 1 1 1 1\nWIDTH "
           << count << "\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS " << count << "\nDATA binary\n";
    }
  }

  void Add(const VoxelPoint& p) {
    const char* xyz = reinterpret_cast<const char*>(p.position.data());
    if (ply_.is_open()) {
      ply_buffer_.insert(ply_buffer_.end(), xyz, xyz + 12);
      ply_buffer_.insert(ply_buffer_.end(), p.rgb.begin(), p.rgb.end());
    }
    if (pcd_.is_open()) {
      // PCL's packed colour: 0x00RRGGBB in the bits of a float field (TYPE F, as PCL writes it;
      // TYPE U makes pcl_pcd2ply write one number where its header promises three).
      const std::uint32_t rgb = (std::uint32_t{p.rgb[0]} << 16) | (std::uint32_t{p.rgb[1]} << 8) |
                                std::uint32_t{p.rgb[2]};
      const char* packed = reinterpret_cast<const char*>(&rgb);
      pcd_buffer_.insert(pcd_buffer_.end(), xyz, xyz + 12);
      pcd_buffer_.insert(pcd_buffer_.end(), packed, packed + 4);
    }
    if (ply_buffer_.size() + pcd_buffer_.size() >= (1u << 20)) Flush();
  }

  void Finish() {
    Flush();
    if (ply_.is_open() && !ply_.flush()) {
      throw std::runtime_error(WriteFailure(ply_path_, "the PLY cloud"));
    }
    if (pcd_.is_open() && !pcd_.flush()) {
      throw std::runtime_error(WriteFailure(pcd_path_, "the PCD cloud"));
    }
  }

 private:
  void Flush() {
    ply_.write(ply_buffer_.data(), static_cast<std::streamsize>(ply_buffer_.size()));
    pcd_.write(pcd_buffer_.data(), static_cast<std::streamsize>(pcd_buffer_.size()));
    ply_buffer_.clear();
    pcd_buffer_.clear();
  }

  std::string ply_path_, pcd_path_;
  std::ofstream ply_, pcd_;
  std::vector<char> ply_buffer_, pcd_buffer_;
};

// The header comments of the voxel cloud's files.
std::vector<std::string> CloudComments(double leaf_size, const std::string& frame) {
  std::ostringstream comment;
  comment << "stillmap voxel cloud, leaf " << leaf_size << " m";
  return {comment.str(), "frame: " + frame};
}

}  // namespace

void WriteCloudFiles(const std::string& ply_path, const std::string& pcd_path,
                     const std::vector<VoxelPoint>& points, double leaf_size,
                     const std::string& frame) {
  CloudFileWriter writer(ply_path, pcd_path, points.size(), CloudComments(leaf_size, frame));
  for (const VoxelPoint& p : points) writer.Add(p);
  writer.Finish();
}

void WritePly(const std::string& path, const std::vector<VoxelPoint>& points) {
  CloudFileWriter writer(path, "", points.size(), {"stillmap point cloud"});
  for (const VoxelPoint& p : points) writer.Add(p);
  writer.Finish();
}

namespace {

// The point count a PLY ("element vertex N") or PCD ("POINTS N") header declares, checked against
// the file's size before PCL allocates for it: every point takes at least 3 bytes (three
// coordinates of one byte, or one character each in ASCII), so a larger count is a damaged header.
void CheckDeclaredPoints(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::error_code error;
  const std::uintmax_t size = std::filesystem::file_size(path, error);
  std::string line;
  for (int lines = 0; lines < 200 && std::getline(in, line); ++lines) {
    std::istringstream fields(line);
    std::string first, second;
    fields >> first;
    unsigned long long count = 0;
    const bool ply = first == "element" && (fields >> second) && second == "vertex";
    if (!(ply || first == "POINTS") || !(fields >> count)) continue;
    if (error || count > size / 3) {
      throw InputError(path + ": the header declares " + std::to_string(count) +
                       " points but the file holds " + std::to_string(size) +
                       " bytes (a damaged or cut-short point cloud)");
    }
    return;
  }
}

}  // namespace

std::vector<VoxelPoint> ReadCloud(const std::string& path) {
  CheckInputFile(path, "point cloud");
  CheckDeclaredPoints(path);
  pcl::PointCloud<pcl::PointXYZRGB> cloud;
  const bool is_pcd = path.size() >= 4 && path.compare(path.size() - 4, 4, ".pcd") == 0;
  int status = -1;
  try {
    status = is_pcd ? pcl::io::loadPCDFile(path, cloud) : pcl::io::loadPLYFile(path, cloud);
  } catch (const std::bad_alloc&) {
    throw InputError(path + ": the point cloud's header asks for more memory than there is");
  }
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
