// The keyframes' final poses refined by dense RGB-D alignment of pairs of them: each keyframe
// to the next ones along the camera's path, and to keyframes of another time whose views overlap
// (the camera came back). Feature poses drift by a fraction of the distance travelled (ORB's
// positions on coarse pyramid levels, docs/figures.md); the depth readings do not. A pose graph
// keeps the poses' shape as they are (loops, joins) and lets the dense alignments, where they
// are taken, set the relative poses. Opt-in (refinement.dense_enabled).
#pragma once

#include <functional>
#include <map>
#include <opencv2/core.hpp>
#include <vector>

#include "stillmap/io/camera.h"
#include "stillmap/io/trajectory.h"
#include "stillmap/pipeline/dense_refinement_options.h"
#include "stillmap/tracking/rgbd_odometry.h"

namespace stillmap {

// A keyframe to refine, with its pose now.
struct RefinedKeyframe {
  int id = 0;
  double time = 0.0;
  Eigen::Isometry3d world_from_camera = Eigen::Isometry3d::Identity();
  // Tracking began anew (relocalized, a new segment) since the keyframe before: the poses'
  // relative pose between the two was not tracked frame to frame.
  bool anew = false;
};

// Gives the `index`th keyframe's gray image (CV_8U) and depth [m] (CV_32F, 0 where unknown or
// moving), full size.
using KeyframeImages = std::function<void(size_t index, cv::Mat* gray, cv::Mat* depth_m)>;

// Refines `keyframes` (in time order; the first holds where it is) in place; `images` is called
// from two threads at once when `parallel`. The same result either way.
DenseRefinementFigures RefineKeyframePoses(const Camera& camera, const KeyframeImages& images,
                                           const DenseRefinementOptions& options,
                                           std::vector<RefinedKeyframe>* keyframes,
                                           bool parallel = false);

// Moves the frames of `trajectory` that `in_map` marks with the keyframes' corrections (after
// against before, by keyframe id; `times` by keyframe id). A keyframe's frame takes its own; a
// frame between keyframes takes the corrections of the keyframes around it averaged over
// `smoothing_s` (a Gaussian's width [s]; 0: interpolated between the two on either side), so
// that it takes the drift they share and not each keyframe's own noise. A frame between
// keyframes more than `max_gap_s` apart (or beyond the first or last) takes the nearer one's
// correction fading to none over `max_gap_s` [s], averaged or not. Only the keyframes of the
// frame's own run count (a run begins at each of the sorted `run_start_times`: where a new map
// segment began), unless its run holds none.
void CarryCorrections(const std::map<int, Eigen::Isometry3d>& before,
                      const std::map<int, Eigen::Isometry3d>& after,
                      const std::map<int, double>& times, const std::vector<bool>& in_map,
                      const std::vector<double>& run_start_times, double smoothing_s,
                      double max_gap_s, Trajectory* trajectory);

}  // namespace stillmap
