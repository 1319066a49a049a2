#include <cmath>

#include "stillmap/tracking/rgbd_residual.h"
#include "tracker_impl.h"

namespace stillmap {

std::optional<Eigen::Isometry3d> Tracker::Impl::DensePose(const Eigen::Isometry3d& predicted,
                                                          double time) {
  const RgbdOdometryOptions& odometry = options.rgbd_odometry;
  if (!have_good || reference_images.depth_m.empty() || current_images.depth_m.empty() ||
      time - reference_time > odometry.max_gap_s) {
    return std::nullopt;
  }
  const Clock::time_point start = Clock::now();
  if (!cell_camera) cell_camera = std::make_unique<CellCamera>(camera, odometry.cell_px);
  const RgbdAlignment alignment =
      AlignRgbd(*cell_camera, reference_images, current_images,
                last_good_camera_from_world * predicted.inverse(), odometry);
  stats.rgbd_odometry_ms += MillisecondsSince(start);
  if (!alignment.ok()) {
    ++stats.rgbd_refused;
    return std::nullopt;
  }
  return alignment.reference_from_current.inverse() * last_good_camera_from_world;
}

bool Tracker::Impl::TrackByRgbdOdometry(const Eigen::Isometry3d& predicted, const LocalSet& local,
                                        FrameData& frame, int with_depth, size_t frame_index,
                                        double time, std::unique_lock<std::mutex>& lock,
                                        TrackResult* result) {
  const RgbdOdometryOptions& odometry = options.rgbd_odometry;
  if (!odometry.enabled) return false;
  const std::optional<Eigen::Isometry3d> camera_from_world = DensePose(predicted, time);
  if (!camera_from_world) return false;
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
    SearchByProjection(*camera_from_world, local, options.matching.refine_search_radius_px, frame,
                       &association);
    matched = association.landmark;
    result->keyframe_id =
        InsertKeyframe(*camera_from_world, frame, association, frame_index, time, lock);
  }
  Accept(*camera_from_world, time, matched, result);
  return true;
}

void Tracker::Impl::CheckByRgbdOdometry(const Eigen::Isometry3d& predicted, const LocalSet& local,
                                        const FrameData& frame, double time, PoseEstimate* estimate,
                                        Association* association) {
  const RgbdOdometryOptions& odometry = options.rgbd_odometry;
  // Frame to frame: the frame before was posed (a lost frame clears have_last), recently.
  if (estimate->inliers >= odometry.check_below_inliers || !have_last ||
      time - reference_time > odometry.check_max_gap_s) {
    return;
  }
  ++stats.rgbd_checked;
  const std::optional<Eigen::Isometry3d> dense = DensePose(predicted, time);
  if (!dense) return;
  const Eigen::Isometry3d difference = *dense * estimate->camera_from_world.inverse();
  const double apart_m = CameraDistance(*dense, estimate->camera_from_world);
  const double turn_deg = RotationAngleDeg(difference);
  if (apart_m <= odometry.check_max_difference_m && turn_deg <= odometry.check_max_difference_deg) {
    return;
  }
  // The map must confirm the dense pose as it confirms a feature pose: an alignment that followed
  // a person across half the image fits few landmarks, and taken frame after frame it runs away
  // from the map.
  const Association feature_association = *association;
  const size_t feature_duplicates = duplicates.size();
  double rmse_px = 0.0;
  const int fitting = MatchAtDensePose(*dense, local, frame, association, &rmse_px);
  if (fitting < odometry.check_min_landmarks) {
    ++stats.rgbd_unconfirmed;
    RestoreMatches(feature_association, association);
    duplicates.resize(feature_duplicates);
    return;
  }
  ++stats.rgbd_replaced;
  estimate->camera_from_world = *dense;
  estimate->inliers = fitting;
  estimate->rmse_px = rmse_px;
}

int Tracker::Impl::MatchAtDensePose(const Eigen::Isometry3d& dense, const LocalSet& local,
                                    const FrameData& frame, Association* association,
                                    double* rmse_px) {
  // The feature matches made the other pose: found again from the dense one, and kept where
  // they fit it.
  ClearMatches(*association);
  ++match_serial;
  SearchByProjection(dense, local, options.matching.refine_search_radius_px, frame, association);
  double squared_px = 0.0;
  int kept = 0;
  for (size_t i = 0; i < association->landmark.size(); ++i) {
    const int id = association->landmark[i];
    if (id < 0) continue;
    const RgbdObservation observation = Observation(frame.features(), i);
    const double limit = observation.depth_m > 0.0 ? options.refinement.chi2_with_depth
                                                   : options.refinement.chi2_without_depth;
    Eigen::Vector3d residual;
    if (!EvaluateRgbdResidual(dense, landmarks.at(id).position, observation, &residual, nullptr) ||
        residual.squaredNorm() >= limit) {
      Unmatch(i, association);
      continue;
    }
    const Eigen::Vector3d q = dense * landmarks.at(id).position;
    squared_px += (q.head<2>() / q.z() - observation.normalized).squaredNorm();
    ++kept;
  }
  *rmse_px = kept > 0 ? std::sqrt(squared_px / kept) * camera.fx : 0.0;
  return kept;
}

}  // namespace stillmap
