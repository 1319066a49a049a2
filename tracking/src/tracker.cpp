#include "stillmap/tracking/tracker.h"

#include <cmath>
#include <cstdint>

#include "stillmap/io/error.h"
#include "tracker_impl.h"

namespace stillmap {

namespace {
// The place index's hash masks: a fixed seed, so that every run indexes alike.
constexpr std::uint64_t kPlaceIndexSeed = 0x5717'1a9e'0000'0027ULL;
}  // namespace

void TrackerOptions::Validate() const {
  features.Validate();
  auto require = [](bool ok, const char* message) {
    if (!ok) throw InputError(message);
  };
  require(search_radius_px > 0.0 && wide_search_radius_px >= search_radius_px &&
              refine_search_radius_px > 0.0,
          "tracking.search_radius_px and tracking.refine_search_radius_px must be positive, "
          "tracking.search_radius_px at most tracking.wide_search_radius_px");
  // The projection search visits the feature-grid cells the radius covers: bounded work.
  require(wide_search_radius_px <= 1000.0 && refine_search_radius_px <= 1000.0,
          "tracking.wide_search_radius_px and tracking.refine_search_radius_px must be at most "
          "1000");
  require(max_descriptor_distance > 0 && max_descriptor_distance <= 256,
          "tracking.max_descriptor_distance must lie in 1..256");
  require(match_ratio > 0.0f && match_ratio <= 1.0f, "tracking.match_ratio must lie in (0, 1]");
  require(min_matches >= 6, "tracking.min_matches must be at least 6");
  require(sigma_px > 0.0 && sigma_inverse_depth > 0.0,
          "tracking.sigma_px and tracking.sigma_inverse_depth must be positive");
  require(depth_calibration_interval > 0,
          "tracking.depth_calibration_interval must be a positive number of keyframes");
  const DepthCorrectionFitOptions& fit = depth_calibration;
  require(fit.min_pairs > 0 && fit.max_residual_m > 0.0 && fit.max_delta > 0.0,
          "tracking.depth_calibration_min_pairs, tracking.depth_calibration_max_residual_m and "
          "tracking.depth_calibration_max_delta must be positive");
  require(fit.coefficient_sigma > 0.0 && fit.residual_sigma_m > 0.0,
          "tracking.depth_calibration_coefficient_sigma and "
          "tracking.depth_calibration_residual_sigma_m must be positive");
  require(fit.min_spread_reduction >= 0.0 && fit.min_spread_reduction_m >= 0.0,
          "tracking.depth_calibration_min_spread_reduction and "
          "tracking.depth_calibration_min_spread_reduction_m must not be negative");
  require(fit.joint_min_keyframes >= 2 && fit.joint_min_significance >= 0.0 &&
              fit.joint_max_weakest_sd > 0.0,
          "tracking.depth_calibration_joint_min_keyframes must be at least 2, "
          "tracking.depth_calibration_joint_min_significance not negative and "
          "tracking.depth_calibration_joint_max_weakest_sd positive");
  require(far_depth > 0.0 && far_depth_power >= 0.0,
          "tracking.far_depth must be positive and tracking.far_depth_power not negative");
  require(min_landmark_depth > 0.0 && max_landmark_depth > min_landmark_depth,
          "tracking.max_landmark_depth must exceed tracking.min_landmark_depth (> 0)");
  require(keyframe_ratio > 0.0 && keyframe_ratio <= 1.0,
          "tracking.keyframe_ratio must lie in (0, 1]");
  require(max_keyframe_interval >= 1 && min_keyframe_interval >= 1 &&
              min_keyframe_interval <= max_keyframe_interval,
          "tracking.min_keyframe_interval must lie in 1..tracking.max_keyframe_interval");
  require(min_keyframe_inliers >= 0 && close_tracked_max >= 0 && close_untracked_min >= 0,
          "tracking.min_keyframe_inliers, tracking.close_tracked_max and "
          "tracking.close_untracked_min must not be negative");
  require(cull_found_ratio >= 0.0 && cull_found_ratio <= 1.0 && cull_min_visible >= 1 &&
              cull_single_view_age >= 1 && cull_recent_age >= cull_single_view_age,
          "tracking.cull_found_ratio must lie in [0, 1], tracking.cull_min_visible and "
          "tracking.cull_single_view_age be at least 1, tracking.cull_recent_age at least "
          "tracking.cull_single_view_age");
  require(local_window >= 2 && local_map_keyframes >= 1,
          "tracking.local_window must be at least 2 and tracking.local_map_keyframes at least 1");
  require(bundle_adjustment_handover_frames >= 0 && bundle_adjustment_handover_frames <= 1000,
          "tracking.bundle_adjustment_handover_frames must be 0..1000");
  require(weak_tracking_inliers >= 0, "tracking.weak_tracking_inliers must not be negative");
  require(close_depth > 0.0, "tracking.close_depth must be positive");
  require(pnp.max_reprojection_error > 0.0 && pnp.refine_reprojection_error > 0.0,
          "tracking.pnp_max_reprojection_error and tracking.pnp_refine_reprojection_error must "
          "be positive");
  require(pnp.iterations >= 1 && pnp.iterations <= 100000,
          "tracking.pnp_iterations must be 1..100000");
  require(pnp.confidence > 0.0 && pnp.confidence < 1.0,
          "tracking.pnp_confidence must be in (0, 1)");
  require(pnp.min_inliers >= 4, "tracking.pnp_min_inliers must be at least 4");
  require(refinement.rounds >= 1 && refinement.rounds <= 20 &&
              refinement.iterations_per_round >= 1 && refinement.iterations_per_round <= 1000,
          "tracking.refinement_rounds must be 1..20 and tracking.refinement_iterations_per_round "
          "1..1000");
  require(refinement.chi2_without_depth > 0.0 && refinement.chi2_with_depth > 0.0,
          "tracking.refinement_chi2_without_depth and tracking.refinement_chi2_with_depth must "
          "be positive");
  require(refinement.min_inliers >= 4, "tracking.refinement_min_inliers must be at least 4");
  require(bundle_adjustment.iterations_first >= 1 && bundle_adjustment.iterations_first <= 1000 &&
              bundle_adjustment.iterations_second >= 1 &&
              bundle_adjustment.iterations_second <= 1000,
          "tracking.bundle_adjustment_iterations_first and _second must be 1..1000");
  require(bundle_adjustment.chi2_without_depth > 0.0 && bundle_adjustment.chi2_with_depth > 0.0,
          "tracking.bundle_adjustment_chi2_without_depth and _chi2_with_depth must be positive");
  require(min_tracked >= 6 && min_relocalized >= min_tracked,
          "tracking.min_tracked must be at least 6 and at most tracking.min_relocalized");
  require(relocalization_keyframes >= 1, "tracking.relocalization_keyframes must be at least 1");
  require(new_map_after_lost >= 1, "tracking.new_map_after_lost must be at least 1");
  require(min_initial_points >= 20, "tracking.min_initial_points must be at least 20");
  require(
      min_static_depth_share >= 0.0 && min_static_depth_share <= 1.0 && max_predicted_frames >= 0,
      "tracking.min_static_depth_share must lie in [0, 1] and tracking.max_predicted_frames "
      "not be negative");
  require(redundant_radius_m >= 0.0 && redundant_axis_angle_deg >= 0.0 &&
              redundant_axis_angle_deg <= 180.0,
          "tracking.redundant_radius_m must not be negative and tracking.redundant_axis_angle_deg "
          "lie in 0..180");
  require(redundant_keyframe_share > 0.0 && redundant_keyframe_share <= 1.0 &&
              redundant_view_angle_deg >= 0.0 && redundant_view_angle_deg <= 180.0 &&
              redundant_scale_ratio >= 1.0,
          "tracking.redundant_keyframe_share must lie in (0, 1], "
          "tracking.redundant_view_angle_deg in 0..180 and tracking.redundant_scale_ratio be at "
          "least 1");
  require(redundant_retire_keyframes >= local_window && redundant_retire_keyframes <= 10000,
          "tracking.redundant_retire_keyframes must be tracking.local_window..10000");
  require(landmark_merge_distance_m >= 0.0,
          "tracking.landmark_merge_distance_m must not be negative");
  place.Validate();
  require(place_candidates >= 1 && place_min_votes >= 1,
          "tracking.place_candidates and tracking.place_min_votes must be at least 1");
  require(loop_min_inliers >= min_tracked && loop_consistency >= 1 && loop_min_separation >= 1,
          "tracking.loop_min_inliers must be at least tracking.min_tracked, "
          "tracking.loop_consistency and tracking.loop_min_separation at least 1");
  require(loop_max_drift_m >= 0.0 && loop_max_drift_share >= 0.0 && loop_max_drift_deg >= 0.0 &&
              loop_max_drift_deg_per_m >= 0.0,
          "tracking.loop_max_drift_m, _share, _deg and _deg_per_m must not be negative");
  require(pose_graph_min_shared >= 1 && pose_graph.iterations >= 1 &&
              pose_graph.iterations <= 1000 && pose_graph.translation_sigma_m > 0.0 &&
              pose_graph.rotation_sigma_rad > 0.0,
          "tracking.pose_graph_min_shared must be at least 1, tracking.pose_graph_iterations "
          "1..1000 and the pose graph's sigmas positive");
  require(loop_handover_frames >= 0 && loop_handover_frames <= 1000 &&
              global_bundle_adjustment_handover_frames >= 0 &&
              global_bundle_adjustment_handover_frames <= 1000,
          "tracking.loop_handover_frames and "
          "tracking.global_bundle_adjustment_handover_frames must be 0..1000");
  require(relocalization_max_distance_m > 0.0 && relocalization_max_speed_mps >= 0.0,
          "tracking.relocalization_max_distance_m must be positive and "
          "tracking.relocalization_max_speed_mps not negative");
}

const char* TrackStatusName(TrackStatus status) {
  switch (status) {
    case TrackStatus::kInitialized:
      return "initialized";
    case TrackStatus::kTracked:
      return "tracked";
    case TrackStatus::kRelocalized:
      return "relocalized";
    case TrackStatus::kNewMap:
      return "new_map";
    case TrackStatus::kOccluded:
      return "occluded";
    case TrackStatus::kPredicted:
      return "predicted";
    case TrackStatus::kLost:
      return "lost";
  }
  return "unknown";
}

Tracker::Impl::Impl(const Camera& camera_in, const TrackerOptions& options_in)
    : camera(camera_in), options(options_in), places(options_in.place, kPlaceIndexSeed) {
  options.Validate();
  double scale = 1.0;
  for (int level = 0; level < options.features.pyramid_levels; ++level) {
    octave_scale.push_back(scale);
    scale *= options.features.scale_factor;
  }
  for (const double u : {0.0, 0.5, 1.0}) {
    for (const double v : {0.0, 0.5, 1.0}) {
      image_outline.emplace_back((u * (camera.width - 1) - camera.cx) / camera.fx,
                                 (v * (camera.height - 1) - camera.cy) / camera.fy);
    }
  }
  if (options.background_bundle_adjustment) worker = std::thread([this] { WorkerLoop(); });
}

Tracker::Impl::~Impl() {
  {
    const std::lock_guard<std::mutex> lock(mutex);
    stopping = true;
  }
  wake.notify_all();
  if (worker.joinable()) worker.join();
}

double Tracker::Impl::OctaveScale(int octave) const {
  return octave_scale[static_cast<size_t>(
      std::clamp(octave, 0, static_cast<int>(octave_scale.size()) - 1))];
}

RgbdObservation Tracker::Impl::Observation(const FrameFeatures& features, size_t i,
                                           bool raw_depth) const {
  RgbdObservation observation;
  observation.normalized = features.normalized[i];
  observation.depth_m =
      features.depth_m[i] * (raw_depth ? 1.0 : DepthFactor(features.normalized[i]));
  observation.sigma_normalized =
      options.sigma_px * OctaveScale(features.keypoints[i].octave) / camera.fx;
  observation.sigma_inverse_depth = options.sigma_inverse_depth;
  if (options.far_depth_power > 0.0 && observation.depth_m > options.far_depth) {
    observation.sigma_inverse_depth *=
        std::pow(observation.depth_m / options.far_depth, options.far_depth_power);
  }
  return observation;
}

double Tracker::Impl::DepthFactor(const Eigen::Vector2d& normalized) const {
  return stats.depth_correction.Factor(normalized.x(), normalized.y());
}

bool Tracker::Impl::UsableDepth(float depth) const {
  return depth >= options.min_landmark_depth && depth <= options.max_landmark_depth;
}

TrackResult Tracker::Impl::Track(size_t frame_index, double time, const cv::Mat& gray,
                                 const cv::Mat& depth_m, const cv::Mat& ignore_mask) {
  const Clock::time_point start = Clock::now();
  TrackResult result;
  FrameData frame(ExtractFeatures(gray, depth_m, camera, ignore_mask, options.features), camera);
  frame.SetImages(depth_m, ignore_mask);
  result.features = static_cast<int>(frame.size());
  result.static_depth_share = StaticDepthShare(depth_m, ignore_mask);
  result.timings.extract_ms = MillisecondsSince(start);

  std::unique_lock<std::mutex> lock(mutex);
  ++frame_serial;
  ++match_serial;
  ++stats.frames;
  duplicates.clear();
  if (pending_loop && frame_serial >= pending_loop->handover_serial) TakeLoopCorrection(lock);
  if (pending && frame_serial >= pending->handover_serial) TakeAdjustment(lock);
  int with_depth = 0;
  for (float depth : frame.features().depth_m) with_depth += UsableDepth(depth) ? 1 : 0;

  if (!have_map) {
    if (with_depth >= options.min_initial_points) {
      const Eigen::Isometry3d pose =
          have_good ? last_good_camera_from_world : Eigen::Isometry3d::Identity();
      StartMap(pose, frame, frame_index, time, lock);
      result.status = TrackStatus::kInitialized;
      result.keyframe_id = map_keyframes.back();
      Accept(pose, time, {}, &result);
    } else {
      ++stats.lost;
    }
    result.timings.total_ms = MillisecondsSince(start);
    return result;
  }

  // Constant-velocity prediction, then projection search (a wider one when it finds little).
  Clock::time_point stage = Clock::now();
  const Eigen::Isometry3d last = have_last ? last_camera_from_world : last_good_camera_from_world;
  const Eigen::Isometry3d predicted = have_velocity ? velocity * last : last;
  const LocalSet local = CollectLocalLandmarks();
  Association association(frame.size());
  SearchByProjection(predicted, local, options.search_radius_px, frame, &association);
  if (association.count() < options.min_matches) {
    SearchByProjection(predicted, local, options.wide_search_radius_px, frame, &association);
  }
  result.timings.match_ms = MillisecondsSince(stage);

  stage = Clock::now();
  PoseEstimate estimate;
  if (association.count() >= options.min_matches) {
    estimate = EstimatePose(predicted, true, local, frame, &association);
  }
  const bool was_lost = consecutive_lost > 0;
  bool relocalizing = was_lost;
  if (!estimate.ok) {
    ClearMatches(association);
    estimate = Relocalize(frame, &association);
    relocalizing = true;
  }
  // A pose found after losing track (or against keyframes instead of the motion model) must be
  // near where the camera was last seen.
  if (estimate.ok && relocalizing && !NearLastGoodPose(estimate.camera_from_world, time)) {
    ++stats.relocalizations_refused;
    ClearMatches(association);
    estimate = {};
  }
  const bool occluded = result.static_depth_share < options.min_static_depth_share;
  result.timings.pose_ms = MillisecondsSince(stage);
  result.matches = estimate.matches;

  stage = Clock::now();
  if (estimate.ok) {
    result.status = occluded   ? TrackStatus::kOccluded
                    : was_lost ? TrackStatus::kRelocalized
                               : TrackStatus::kTracked;
    if (was_lost) ++stats.relocalized;
    if (occluded) ++stats.occluded;
    result.inliers = estimate.inliers;
    result.reprojection_rmse_px = estimate.rmse_px;
    CountVisibility(estimate.camera_from_world, local, association);
    MergeDuplicates(estimate.camera_from_world, frame, &association);
    ++frames_since_keyframe;
    consecutive_predicted = 0;
    if (!occluded && NeedKeyframe(frame, association, estimate.inliers)) {
      result.keyframe_id =
          InsertKeyframe(estimate.camera_from_world, frame, association, frame_index, time, lock);
    }
    Accept(estimate.camera_from_world, time, association.landmark, &result);
  } else if (occluded && have_last && consecutive_predicted < options.max_predicted_frames) {
    // Nothing to track behind the occluder: the motion model carries the pose through.
    ++consecutive_predicted;
    ++stats.predicted;
    result.status = TrackStatus::kPredicted;
    Accept(predicted, time, {}, &result);
  } else {
    ++consecutive_lost;
    ++stats.lost;
    have_last = false;
    have_velocity = false;
    if (consecutive_lost >= options.new_map_after_lost &&
        with_depth >= options.min_initial_points) {
      StartMap(last_good_camera_from_world, frame, frame_index, time, lock);
      ++stats.new_maps;
      --stats.lost;
      result.status = TrackStatus::kNewMap;
      result.keyframe_id = map_keyframes.back();
      Accept(last_good_camera_from_world, time, {}, &result);
    }
  }
  result.timings.keyframe_ms = MillisecondsSince(stage);
  result.timings.total_ms = MillisecondsSince(start);
  return result;
}

void Tracker::Impl::CountVisibility(const Eigen::Isometry3d& camera_from_world,
                                    const LocalSet& local, const Association& association) {
  for (const auto& [id, landmark] : local) {
    const Eigen::Vector3d p = camera_from_world * landmark->position;
    if (p.z() < options.min_landmark_depth) continue;
    const double u = camera.fx * p.x() / p.z() + camera.cx;
    const double v = camera.fy * p.y() / p.z() + camera.cy;
    if (u >= 0.0 && v >= 0.0 && u < camera.width && v < camera.height) ++landmark->visible;
  }
  for (int id : association.landmark) {
    if (id >= 0) ++landmarks.at(id).found;
  }
}

double StaticDepthShare(const cv::Mat& depth_m, const cv::Mat& ignore_mask) {
  if (depth_m.empty()) return 0.0;
  size_t count = 0;  // one pass, no temporary images: this runs on every frame
  for (int v = 0; v < depth_m.rows; ++v) {
    const float* z = depth_m.ptr<float>(v);
    const std::uint8_t* ignored = ignore_mask.empty() ? nullptr : ignore_mask.ptr<std::uint8_t>(v);
    for (int u = 0; u < depth_m.cols; ++u) {
      count += z[u] > 0.0f && (ignored == nullptr || ignored[u] == 0) ? 1 : 0;
    }
  }
  return static_cast<double>(count) / static_cast<double>(depth_m.total());
}

bool Tracker::Impl::NearLastGoodPose(const Eigen::Isometry3d& camera_from_world,
                                     double time) const {
  if (!have_good) return true;
  const double distance = (camera_from_world.inverse().translation() -
                           last_good_camera_from_world.inverse().translation())
                              .norm();
  const double elapsed_s = std::max(0.0, time - last_good_time);
  return distance <=
         options.relocalization_max_distance_m + options.relocalization_max_speed_mps * elapsed_s;
}

void Tracker::Impl::Accept(const Eigen::Isometry3d& camera_from_world, double time,
                           const std::vector<int>& matched, TrackResult* result) {
  if (have_last) velocity = camera_from_world * last_camera_from_world.inverse();
  have_velocity = have_last;
  have_last = true;
  last_camera_from_world = camera_from_world;
  have_good = true;
  last_good_camera_from_world = camera_from_world;
  last_good_time = time;
  consecutive_lost = 0;
  last_frame_landmarks.clear();
  for (int id : matched) {
    if (id >= 0) last_frame_landmarks.push_back(id);
  }
  const Keyframe& reference = keyframes.at(map_keyframes.back());
  // A frame that became the keyframe is its own reference. An inline bundle adjustment may
  // already have moved the keyframe: the frame moves with it.
  const Eigen::Isometry3d camera_from_reference =
      result->keyframe_id == reference.id
          ? Eigen::Isometry3d::Identity()
          : camera_from_world * reference.camera_from_world.inverse();
  records.push_back({time, reference.id, camera_from_reference});
  ++stats.tracked;
  result->world_from_camera = camera_from_world.inverse();
}

Tracker::Tracker(const Camera& camera, const TrackerOptions& options)
    : impl_(std::make_unique<Impl>(camera, options)) {}

Tracker::~Tracker() = default;

TrackResult Tracker::Track(size_t frame_index, double time, const cv::Mat& gray,
                           const cv::Mat& depth_m, const cv::Mat& ignore_mask) {
  return impl_->Track(frame_index, time, gray, depth_m, ignore_mask);
}

std::optional<Eigen::Isometry3d> Tracker::PredictedPose() const {
  const std::lock_guard<std::mutex> lock(impl_->mutex);
  if (!impl_->have_map || !impl_->have_last) return std::nullopt;
  const Eigen::Isometry3d predicted = impl_->have_velocity
                                          ? impl_->velocity * impl_->last_camera_from_world
                                          : impl_->last_camera_from_world;
  return predicted.inverse();
}

std::vector<FinalKeyframe> Tracker::TakeFinalKeyframes() {
  const std::lock_guard<std::mutex> lock(impl_->mutex);
  std::vector<FinalKeyframe> out;
  out.swap(impl_->final_queue);
  return out;
}

void Tracker::Finish() {
  std::unique_lock<std::mutex> lock(impl_->mutex);
  impl_->TakeLoopCorrection(lock);
  impl_->TakeAdjustment(lock);
  impl_->RequestAdjustment();  // a last one over the final window
  impl_->TakeAdjustment(lock);
  impl_->UpdateFinal(true);
}

Trajectory Tracker::TrackedTrajectory() const {
  const std::lock_guard<std::mutex> lock(impl_->mutex);
  std::vector<StampedPose> poses;
  poses.reserve(impl_->records.size());
  for (const FrameRecord& record : impl_->records) {
    poses.push_back({record.time, (record.camera_from_reference *
                                   impl_->CameraFromWorld(record.reference_keyframe))
                                      .inverse()});
  }
  return Trajectory(std::move(poses));
}

std::map<int, Eigen::Isometry3d> Tracker::KeyframePoses() const {
  const std::lock_guard<std::mutex> lock(impl_->mutex);
  std::map<int, Eigen::Isometry3d> out;
  for (const auto& [id, keyframe] : impl_->keyframes) {
    out.emplace(id, keyframe.camera_from_world.inverse());
  }
  for (const auto& entry : impl_->culled) {  // posed through the keyframes they were handed to
    out.emplace(entry.first, impl_->CameraFromWorld(entry.first).inverse());
  }
  return out;
}

size_t Tracker::pose_corrections() const {
  const std::lock_guard<std::mutex> lock(impl_->mutex);
  return impl_->stats.loops_accepted + impl_->stats.global_bundle_adjustments;
}

DepthCorrection Tracker::depth_correction() const {
  const std::lock_guard<std::mutex> lock(impl_->mutex);
  return impl_->stats.depth_correction;
}

TrackerStatistics Tracker::statistics() const {
  const std::lock_guard<std::mutex> lock(impl_->mutex);
  TrackerStatistics stats = impl_->stats;
  stats.landmarks = impl_->landmarks.size();
  stats.place_index_mib = static_cast<double>(impl_->places.MemoryBytes()) / (1024.0 * 1024.0);
  return stats;
}

}  // namespace stillmap
