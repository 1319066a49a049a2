// The camera's up from the floor its keyframes saw (floor_up.h).
#include "floor_up.h"

#include <algorithm>
#include <cmath>
#include <vector>

namespace stillmap {
namespace {

double AngleDeg(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::atan2(a.cross(b).norm(), a.dot(b)) * 180.0 / M_PI;
}

// The indices of the map's keyframes among the fuser's, at most `count`, spread evenly.
std::vector<size_t> SpreadMapKeyframes(const KeyframeFuser& fuser, const SegmentKeeper& segments,
                                       size_t count) {
  const std::vector<KeyframeFuser::KeptKeyframe> kept = fuser.KeptKeyframes();
  std::vector<size_t> in_map;
  for (size_t k = 0; k < kept.size(); ++k) {
    if (!kept[k].apart && segments.KeyframeInMap(kept[k].keyframe_id)) in_map.push_back(k);
  }
  if (in_map.size() <= count) return in_map;
  std::vector<size_t> spread;
  spread.reserve(count);
  for (size_t i = 0; i < count; ++i) spread.push_back(in_map[i * in_map.size() / count]);
  return spread;
}

}  // namespace

FloorUpFigures UpFromFloor(const Camera& camera, const KeyframeFuser& fuser,
                           const SegmentKeeper& segments, const FloorNormalOptions& options,
                           Eigen::Vector3d* up_in_camera) {
  FloorUpFigures figures;
  figures.tracked_up_in_camera = *up_in_camera;
  const std::vector<Eigen::Vector2f> rays = PixelRays(camera);
  std::vector<Eigen::Vector3d> normals;
  for (const size_t k :
       SpreadMapKeyframes(fuser, segments, static_cast<size_t>(options.max_keyframes))) {
    cv::Mat gray, depth_m;
    fuser.ImagesOf(k, &gray, &depth_m);
    ++figures.keyframes_read;
    if (std::optional<Eigen::Vector3d> normal =
            FloorNormalInCamera(rays, depth_m, *up_in_camera, options)) {
      normals.push_back(*normal);
    }
  }
  figures.keyframes_seeing_floor = normals.size();
  const std::optional<Eigen::Vector3d> median = MedianDirection(normals);
  if (!median || normals.size() < static_cast<size_t>(options.min_keyframes)) return figures;
  std::vector<double> angles_deg;
  angles_deg.reserve(normals.size());
  for (const Eigen::Vector3d& normal : normals) angles_deg.push_back(AngleDeg(normal, *median));
  std::nth_element(angles_deg.begin(), angles_deg.begin() + angles_deg.size() / 2,
                   angles_deg.end());
  figures.spread_deg = angles_deg[angles_deg.size() / 2];
  figures.change_deg = AngleDeg(*up_in_camera, *median);
  figures.taken = true;
  *up_in_camera = *median;
  return figures;
}

}  // namespace stillmap
