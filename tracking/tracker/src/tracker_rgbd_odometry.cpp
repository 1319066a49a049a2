#include "tracker_impl.h"

namespace stillmap {

bool Tracker::Impl::TrackByRgbdOdometry(const Eigen::Isometry3d& predicted, const LocalSet& local,
                                        FrameData& frame, int with_depth, size_t frame_index,
                                        double time, std::unique_lock<std::mutex>& lock,
                                        TrackResult* result) {
  const RgbdOdometryOptions& odometry = options.rgbd_odometry;
  if (!odometry.enabled || !have_good || reference_images.depth_m.empty() ||
      current_images.depth_m.empty() || time - reference_time > odometry.max_gap_s) {
    return false;
  }
  const Clock::time_point start = Clock::now();
  if (!cell_camera) cell_camera = std::make_unique<CellCamera>(camera, odometry.cell_px);
  const RgbdAlignment alignment =
      AlignRgbd(*cell_camera, reference_images, current_images,
                last_good_camera_from_world * predicted.inverse(), odometry);
  stats.rgbd_odometry_ms += MillisecondsSince(start);
  if (!alignment.ok()) {
    ++stats.rgbd_refused;
    return false;
  }
  const Eigen::Isometry3d camera_from_world =
      alignment.reference_from_current.inverse() * last_good_camera_from_world;
  ++stats.rgbd_posed;
  result->status = TrackStatus::kRgbdOdometry;
  ++frames_since_keyframe;
  consecutive_predicted = 0;
  std::vector<int> matched;
  if (frames_since_keyframe >= odometry.keyframe_interval &&
      with_depth >= options.relocalization.min_initial_points) {
    // The local landmarks in view keep the new keyframe in the covisibility graph.
    Association association(frame.size());
    ++match_serial;
    SearchByProjection(camera_from_world, local, options.matching.refine_search_radius_px, frame,
                       &association);
    matched = association.landmark;
    result->keyframe_id =
        InsertKeyframe(camera_from_world, frame, association, frame_index, time, lock);
  }
  Accept(camera_from_world, time, matched, result);
  return true;
}

}  // namespace stillmap
