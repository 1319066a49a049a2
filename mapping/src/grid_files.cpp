// The grid's files: grid.pgm and grid.yaml as ROS map_server reads them, and back.
#include <yaml-cpp/yaml.h>

#include <filesystem>
#include <fstream>
#include <iomanip>
#include <opencv2/imgcodecs.hpp>
#include <stdexcept>

#include "stillmap/io/error.h"
#include "stillmap/io/yaml_file.h"
#include "stillmap/mapping/occupancy_grid.h"

namespace stillmap {

void WriteGrid(const OccupancyGrid& grid, const std::string& pgm_path, const std::string& yaml_path,
               const std::string& image_name) {
  {
    std::ofstream out(pgm_path, std::ios::binary);
    out << "P5\n# stillmap occupancy grid: 0 occupied, 254 free, 205 unknown\n"
        << grid.width << " " << grid.height << "\n255\n";
    std::vector<unsigned char> row(static_cast<size_t>(grid.width));
    for (int j = grid.height - 1; j >= 0; --j) {  // the image's top row is the highest y
      for (int i = 0; i < grid.width; ++i) {
        const std::int8_t value = grid.At(i, j);
        row[static_cast<size_t>(i)] = value == kGridOccupied ? 0 : value == kGridFree ? 254 : 205;
      }
      out.write(reinterpret_cast<const char*>(row.data()),
                static_cast<std::streamsize>(row.size()));
    }
    if (!out.flush()) throw std::runtime_error(WriteFailure(pgm_path, "the grid image"));
  }
  std::ofstream out(yaml_path);
  out << std::setprecision(9);
  const Eigen::Matrix4d m = grid.world_from_grid.matrix();
  out << "# stillmap 2-D occupancy grid (ROS map_server format).\n"
      << "# Frame: x, y in the floor plane, z up from the floor; the origin lies on the floor\n"
      << "# under the first camera, x along its view. world_from_map places this frame in the\n"
      << "# frame of stillmap's 3-D outputs (map.ply, map.bt, trajectory.txt; report.json\n"
      << "# map_frame), row-major 4x4: the identity when map.frame=floor.\n"  // file format
      << "# Occupied: an occupied OctoMap voxel between min_height and max_height above the\n"
      << "# floor, with voxel-cloud points there; free: that band observed free, or the floor\n"
      << "# seen with nothing above it.\n"
      << "image: " << image_name << "\n"
      << "resolution: " << grid.resolution << "\n"
      << "origin: [" << grid.origin.x() << ", " << grid.origin.y() << ", 0.0]\n"
      << "negate: 0\n"
      << "occupied_thresh: 0.65\n"
      << "free_thresh: 0.196\n"
      << "mode: trinary\n"
      << "min_height: " << grid.min_height << "\n"
      << "max_height: " << grid.max_height << "\n"
      << "floor_source: \"" << grid.floor.source << "\"\n"
      << "world_from_map: [";
  // Rounding leaves 1e-17 where a rotation's entry is 0 (cos 90 deg): written as 0 (and 1 as 1).
  const auto tidy = [](double value) {
    for (const double exact : {0.0, 1.0, -1.0}) {
      if (std::abs(value - exact) < 1e-12) return exact;
    }
    return value;
  };
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) out << (r + c > 0 ? ", " : "") << tidy(m(r, c));
  }
  out << "]\n";
  if (!out.flush()) throw std::runtime_error(WriteFailure(yaml_path, "the grid description"));
}

OccupancyGrid ReadGrid(const std::string& yaml_path) {
  const YAML::Node yaml = LoadYamlFile(yaml_path, "grid description");
  auto need = [&](const char* key) {
    if (!yaml[key]) throw InputError(yaml_path + ": missing key '" + key + "'");
    return yaml[key];
  };
  OccupancyGrid grid;
  try {
    grid.resolution = need("resolution").as<double>();
    const auto origin = need("origin").as<std::vector<double>>();
    if (origin.size() != 3) throw InputError(yaml_path + ": 'origin' needs [x, y, yaw]");
    grid.origin = Eigen::Vector2d(origin[0], origin[1]);
    grid.min_height = need("min_height").as<double>();
    grid.max_height = need("max_height").as<double>();
    const auto m = need("world_from_map").as<std::vector<double>>();
    if (m.size() != 16) throw InputError(yaml_path + ": 'world_from_map' needs 16 numbers");
    Eigen::Matrix4d matrix;
    for (int k = 0; k < 16; ++k) matrix(k / 4, k % 4) = m[static_cast<size_t>(k)];
    grid.world_from_grid.matrix() = matrix;
    if (yaml["floor_source"]) grid.floor.source = yaml["floor_source"].as<std::string>();
  } catch (const YAML::Exception& e) {
    throw InputError(WhereInFile(yaml_path, e.mark.line + 1) + ": malformed grid description (" +
                     YamlProblem(e.msg) + ")");
  }
  // The map frame's z is the floor's normal and its origin lies on the floor.
  grid.floor.up = grid.world_from_grid.linear().col(2);
  grid.floor.offset = -grid.floor.up.dot(grid.world_from_grid.translation());
  const std::string image_path =
      (std::filesystem::path(yaml_path).parent_path() / need("image").as<std::string>()).string();
  const cv::Mat image = cv::imread(image_path, cv::IMREAD_UNCHANGED);
  if (image.empty() || image.type() != CV_8UC1) {
    throw InputError(image_path + ": missing, unreadable or not an 8-bit gray image");
  }
  grid.width = image.cols;
  grid.height = image.rows;
  grid.cells.assign(static_cast<size_t>(grid.width) * static_cast<size_t>(grid.height),
                    kGridUnknown);
  for (int row = 0; row < image.rows; ++row) {
    for (int col = 0; col < image.cols; ++col) {
      const std::uint8_t p = image.at<std::uint8_t>(row, col);
      const size_t j = static_cast<size_t>(grid.height - 1 - row);
      grid.cells[j * static_cast<size_t>(grid.width) + static_cast<size_t>(col)] =
          p == 0     ? kGridOccupied
          : p == 254 ? kGridFree
                     : kGridUnknown;
    }
  }
  return grid;
}

}  // namespace stillmap
