#include "stillmap/mapping/occupancy_map.h"

#include <octomap/OcTree.h>

#include <cmath>
#include <fstream>
#include <stdexcept>

#include "stillmap/io/error.h"

namespace stillmap {

void OccupancyMapOptions::Validate() const {
  if (!(resolution >= 0.005 && resolution <= 5.0)) {
    throw InputError("octomap.resolution must be between 0.005 and 5 m");
  }
  if (!(probability_hit > 0.5 && probability_hit < 1.0)) {
    throw InputError("octomap.probability_hit must be in (0.5, 1)");
  }
  if (!(probability_miss > 0.0 && probability_miss < 0.5)) {
    throw InputError("octomap.probability_miss must be in (0, 0.5)");
  }
  if (!(clamping_min > 0.0 && clamping_min < 0.5 && clamping_max > 0.5 && clamping_max < 1.0)) {
    throw InputError("octomap.clamping_min must be in (0, 0.5) and clamping_max in (0.5, 1)");
  }
}

struct OccupancyMap::Impl {
  explicit Impl(const OccupancyMapOptions& o) : options(o), tree(o.resolution) {
    tree.setProbHit(o.probability_hit);
    tree.setProbMiss(o.probability_miss);
    tree.setClampingThresMin(o.clamping_min);
    tree.setClampingThresMax(o.clamping_max);
  }
  OccupancyMapOptions options;
  octomap::OcTree tree;
  octomap::Pointcloud scan;  // reused between insertions
  size_t rejected = 0;
  bool Inside(double x, double y, double z) const {
    const double limit = OccupancyMap::Extent(tree.getResolution());
    return std::abs(x) < limit && std::abs(y) < limit && std::abs(z) < limit;
  }
};

OccupancyMap::OccupancyMap(const OccupancyMapOptions& options) {
  options.Validate();
  impl_ = std::make_unique<Impl>(options);
}

OccupancyMap::~OccupancyMap() = default;
OccupancyMap::OccupancyMap(OccupancyMap&&) noexcept = default;
OccupancyMap& OccupancyMap::operator=(OccupancyMap&&) noexcept = default;

void OccupancyMap::InsertScan(const std::vector<Eigen::Vector3f>& points_in_world,
                              const Eigen::Vector3f& sensor_origin_in_world) {
  if (!impl_->Inside(sensor_origin_in_world.x(), sensor_origin_in_world.y(),
                     sensor_origin_in_world.z())) {
    impl_->rejected += points_in_world.size();
    return;
  }
  octomap::Pointcloud& scan = impl_->scan;
  scan.clear();
  scan.reserve(points_in_world.size());
  for (const Eigen::Vector3f& p : points_in_world) {
    if (impl_->Inside(p.x(), p.y(), p.z())) {
      scan.push_back(p.x(), p.y(), p.z());
    } else {
      ++impl_->rejected;
    }
  }
  const octomap::point3d origin(sensor_origin_in_world.x(), sensor_origin_in_world.y(),
                                sensor_origin_in_world.z());
  impl_->tree.insertPointCloud(scan, origin, impl_->options.max_range, /*lazy_eval=*/false,
                               /*discretize=*/true);
}

double OccupancyMap::Occupancy(const Eigen::Vector3d& point_in_world) const {
  if (!impl_->Inside(point_in_world.x(), point_in_world.y(), point_in_world.z())) return -1.0;
  const octomap::OcTreeNode* node =
      impl_->tree.search(point_in_world.x(), point_in_world.y(), point_in_world.z());
  return node == nullptr ? -1.0 : node->getOccupancy();
}

void OccupancyMap::ForEachLeaf(const std::function<void(const Eigen::Vector3d& centre, double size,
                                                        bool occupied)>& visit) const {
  const octomap::OcTree& tree = impl_->tree;
  for (auto it = tree.begin_leafs(); it != tree.end_leafs(); ++it) {
    const octomap::point3d centre = it.getCoordinate();
    visit(Eigen::Vector3d(centre.x(), centre.y(), centre.z()), it.getSize(),
          tree.isNodeOccupied(*it));
  }
}

size_t OccupancyMap::rejected_count() const { return impl_->rejected; }

size_t OccupancyMap::LeafCount() const { return impl_->tree.getNumLeafNodes(); }

size_t OccupancyMap::OccupiedLeafCount() const {
  size_t count = 0;
  for (auto it = impl_->tree.begin_leafs(); it != impl_->tree.end_leafs(); ++it) {
    if (impl_->tree.isNodeOccupied(*it)) ++count;
  }
  return count;
}

size_t OccupancyMap::MemoryBytes() const { return impl_->tree.memoryUsage(); }

double OccupancyMap::resolution() const { return impl_->tree.getResolution(); }

void OccupancyMap::WriteBinary(const std::string& path) const {
  std::ofstream out(path, std::ios::binary);
  // The header of OctoMap's .bt format, then its binary node data. Debian's liboctomap is built
  // with debug output, and writeBinaryConst() would print " done." on stderr even with --quiet.
  out << "# Octomap OcTree binary file\n"
      << "# (feel free to add / change comments, but leave the first line as it is!)\n#\n"
      << "id " << impl_->tree.getTreeType() << "\n"
      << "size " << impl_->tree.size() << "\n"
      << "res " << impl_->tree.getResolution() << "\n"
      << "data\n";
  if (!out || !impl_->tree.writeBinaryData(out) || !out.flush()) {
    throw std::runtime_error(path + ": could not write the OctoMap (.bt)");
  }
}

void OccupancyMap::WriteFull(const std::string& path) const {
  std::ofstream out(path, std::ios::binary);
  if (!out || !impl_->tree.write(out) || !out.flush()) {
    throw std::runtime_error(path + ": could not write the OctoMap (.ot)");
  }
}

}  // namespace stillmap
