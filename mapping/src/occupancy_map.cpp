#include "stillmap/mapping/occupancy_map.h"

#include <fmt/format.h>
#include <octomap/OcTree.h>

#include <cmath>
#include <fstream>
#include <stdexcept>

#include "stillmap/io/error.h"
#include "stillmap/io/option_names.h"

namespace stillmap {

void OccupancyMapOptions::Validate() const {
  if (!(resolution >= 0.005 && resolution <= 5.0)) {
    throw InputError(fmt::format("{} must be between 0.005 and 5 m", OptionKey(*this, resolution)));
  }
  if (!(probability_hit > 0.5 && probability_hit < 1.0)) {
    throw InputError(fmt::format("{} must be in (0.5, 1)", OptionKey(*this, probability_hit)));
  }
  if (!(probability_miss > 0.0 && probability_miss < 0.5)) {
    throw InputError(fmt::format("{} must be in (0, 0.5)", OptionKey(*this, probability_miss)));
  }
  if (!(clamping_min > 0.0 && clamping_min < 0.5 && clamping_max > 0.5 && clamping_max < 1.0)) {
    throw InputError(fmt::format("{} must be in (0, 0.5) and clamping_max in (0.5, 1)",
                                 OptionKey(*this, clamping_min)));
  }
  if (!(later_session_decisive_hits >= 0.0 && later_session_decisive_hits <= 100.0)) {
    throw InputError(
        fmt::format("{} must be in [0, 100]", OptionKey(*this, later_session_decisive_hits)));
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

namespace {

// Sets the voxels of `to` whose centres lie in `leaf` of `from`, grown by `grow` on each side, to
// the leaf's log-odds; with `keep_higher`, a voxel keeps a higher value it already has.
void Resample(const octomap::OcTree::leaf_iterator& leaf, const Eigen::Isometry3d& new_from_old,
              const Eigen::Isometry3d& old_from_new, double grow, bool keep_higher,
              octomap::OcTree* to) {
  const Eigen::Vector3d centre(leaf.getX(), leaf.getY(), leaf.getZ());
  const double half = leaf.getSize() / 2.0 + grow;
  // The new voxels whose centres may lie in the leaf: the rotated cube's bounding box.
  const Eigen::Vector3d reach = new_from_old.linear().cwiseAbs() * Eigen::Vector3d::Constant(half);
  const Eigen::Vector3d low = new_from_old * centre - reach, high = new_from_old * centre + reach;
  octomap::OcTreeKey first, last;
  if (!to->coordToKeyChecked(octomap::point3d(low.x(), low.y(), low.z()), first) ||
      !to->coordToKeyChecked(octomap::point3d(high.x(), high.y(), high.z()), last)) {
    return;
  }
  const float log_odds = leaf->getLogOdds();
  for (int a = first[0]; a <= last[0]; ++a) {
    for (int b = first[1]; b <= last[1]; ++b) {
      for (int c = first[2]; c <= last[2]; ++c) {
        const octomap::OcTreeKey key(static_cast<octomap::key_type>(a),
                                     static_cast<octomap::key_type>(b),
                                     static_cast<octomap::key_type>(c));
        const octomap::point3d at = to->keyToCoord(key);
        const Eigen::Vector3d offset =
            old_from_new * Eigen::Vector3d(at.x(), at.y(), at.z()) - centre;
        // Half-open, so that a centre on a shared face belongs to one leaf.
        if (!((offset.array() >= -half).all() && (offset.array() < half).all())) continue;
        if (keep_higher) {
          const octomap::OcTreeNode* node = to->search(key);
          if (node != nullptr && node->getLogOdds() >= log_odds) continue;
        }
        to->setNodeValue(key, log_odds, /*lazy_eval=*/true);
      }
    }
  }
}

}  // namespace

OccupancyMap OccupancyMap::Transformed(const Eigen::Isometry3d& new_from_old) const {
  OccupancyMap result(impl_->options);
  result.impl_->rejected = impl_->rejected;
  const octomap::OcTree& from = impl_->tree;
  octomap::OcTree& to = result.impl_->tree;
  const Eigen::Isometry3d old_from_new = new_from_old.inverse();
  for (auto it = from.begin_leafs(); it != from.end_leafs(); ++it) {
    if (!from.isNodeOccupied(*it)) Resample(it, new_from_old, old_from_new, 0.0, false, &to);
  }
  // Occupied leaves grown by a quarter voxel: a one-voxel wall then holds a new voxel centre in
  // every column of the new lattice through it, so rays cannot slip through it.
  const double grow = from.getResolution() / 4.0;
  for (auto it = from.begin_leafs(); it != from.end_leafs(); ++it) {
    if (from.isNodeOccupied(*it)) Resample(it, new_from_old, old_from_new, grow, true, &to);
  }
  to.updateInnerOccupancy();
  to.prune();
  return result;
}

double OccupancyMapOptions::DecisiveLogOdds() const {
  return later_session_decisive_hits * std::log(probability_hit / (1.0 - probability_hit));
}

void OccupancyMap::Overlay(const OccupancyMap& later, double decisive_log_odds) {
  octomap::OcTree& tree = impl_->tree;
  const octomap::OcTree& other = later.impl_->tree;
  const unsigned max_depth = tree.getTreeDepth();
  for (auto it = other.begin_leafs(), end = other.end_leafs(); it != end; ++it) {
    const float value = it->getLogOdds();
    const bool decisive = std::abs(value) >= decisive_log_odds;
    // A pruned leaf stands for 2^(max_depth - depth) voxels along each axis: each is set.
    const octomap::OcTreeKey first = it.getIndexKey();
    const unsigned side = 1u << (max_depth - it.getDepth());
    for (unsigned dx = 0; dx < side; ++dx) {
      for (unsigned dy = 0; dy < side; ++dy) {
        for (unsigned dz = 0; dz < side; ++dz) {
          const octomap::OcTreeKey key(static_cast<octomap::key_type>(first[0] + dx),
                                       static_cast<octomap::key_type>(first[1] + dy),
                                       static_cast<octomap::key_type>(first[2] + dz));
          if (decisive) {
            tree.setNodeValue(key, value, true);
          } else {
            tree.updateNode(key, value, true);
          }
        }
      }
    }
  }
  tree.updateInnerOccupancy();
  tree.prune();
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

double OccupancyMap::max_range() const { return impl_->options.max_range; }

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
    throw std::runtime_error(WriteFailure(path, "the OctoMap (.bt)"));
  }
}

void OccupancyMap::WriteFull(const std::string& path) const {
  std::ofstream out(path, std::ios::binary);
  if (!out || !impl_->tree.write(out) || !out.flush()) {
    throw std::runtime_error(WriteFailure(path, "the OctoMap (.ot)"));
  }
}

}  // namespace stillmap
