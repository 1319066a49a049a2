#include "stillmap/tracking/tracker.h"

#include <cmath>
#include <cstdint>

#include "tracker_impl.h"

namespace stillmap {

namespace {
// The place index's hash masks: a fixed seed, so that every run indexes alike.
constexpr std::uint64_t kPlaceIndexSeed = 0x5717'1a9e'0000'0027ULL;
}  // namespace

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
    case TrackStatus::kCarried:
      return "carried";
    case TrackStatus::kRgbdOdometry:
      return "rgbd_odometry";
    case TrackStatus::kLost:
      return "lost";
  }
  return "unknown";
}

Tracker::Impl::Impl(const Camera& camera_in, const TrackerOptions& options_in)
    : camera(camera_in), options(options_in), loops(options_in.loops, kPlaceIndexSeed) {
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
  if (options.local_map.background_bundle_adjustment)
    worker = std::thread([this] { WorkerLoop(); });
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
      options.matching.sigma_px * OctaveScale(features.keypoints[i].octave) / camera.fx;
  observation.sigma_inverse_depth = options.matching.sigma_inverse_depth;
  if (options.matching.far_depth_power > 0.0 && observation.depth_m > options.matching.far_depth) {
    observation.sigma_inverse_depth *= std::pow(observation.depth_m / options.matching.far_depth,
                                                options.matching.far_depth_power);
  }
  return observation;
}

double Tracker::Impl::DepthFactor(const Eigen::Vector2d& normalized) const {
  return stats.depth_correction.Factor(normalized.x(), normalized.y());
}

bool Tracker::Impl::UsableDepth(float depth) const {
  return depth >= options.matching.min_landmark_depth &&
         depth <= options.matching.max_landmark_depth;
}

TrackResult Tracker::Impl::Track(size_t frame_index, double time, const cv::Mat& gray,
                                 const cv::Mat& depth_m, const cv::Mat& ignore_mask) {
  const Clock::time_point start = Clock::now();
  TrackResult result;
  FrameData frame(ExtractFeatures(gray, depth_m, camera, ignore_mask, options.features), camera);
  frame.SetImages(depth_m, ignore_mask);
  current_images = {gray, depth_m, ignore_mask};
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
    TrackWithoutMap(frame, with_depth, frame_index, time, lock, &result);
    EndFrame(time, start, &result);
    return result;
  }

  // The prior's or constant-velocity prediction, then projection search (a wider one when it
  // finds little).
  Clock::time_point stage = Clock::now();
  const Eigen::Isometry3d last = have_last ? last_camera_from_world : last_good_camera_from_world;
  Eigen::Isometry3d predicted = Predict(last, time);
  const LocalSet local = CollectLocalLandmarks();
  Association association(frame.size());
  // Past the wait the camera is not looked for in the map: a pose found now may lie metres off
  // (the unseen motion), and the next view with enough points begins a new segment instead.
  const bool past_wait = PastNewMapWait();
  if (!past_wait) SearchAroundPredictions(&predicted, local, frame, &association);
  result.timings.match_ms = MillisecondsSince(stage);

  stage = Clock::now();
  PoseEstimate estimate =
      past_wait ? PoseEstimate{} : FindPose(predicted, local, frame, time, &association);
  if (estimate.ok) CheckByRgbdOdometry(predicted, local, frame, time, &estimate, &association);
  const bool occluded = result.static_depth_share < options.relocalization.min_static_depth_share;
  result.timings.pose_ms = MillisecondsSince(stage);
  result.matches = estimate.matches;

  stage = Clock::now();
  if (estimate.ok) {
    TakePose(estimate, local, frame, &association, &result);
    if (!occluded && NeedKeyframe(frame, association, estimate.inliers)) {
      result.keyframe_id =
          InsertKeyframe(estimate.camera_from_world, frame, association, frame_index, time, lock);
    }
    Accept(estimate.camera_from_world, time, association.landmark, &result);
  } else {
    TrackWithoutPose(predicted, local, frame, with_depth, frame_index, time, lock, &result);
  }
  result.timings.keyframe_ms = MillisecondsSince(stage);
  EndFrame(time, start, &result);
  return result;
}

void Tracker::Impl::EndFrame(double time, Clock::time_point start, TrackResult* result) {
  if (result->tracked()) {  // the next frame's reference for dense alignment
    reference_images = current_images;
    reference_time = time;
  }
  next_prior.reset();
  result->timings.total_ms = MillisecondsSince(start);
}

void Tracker::Impl::TrackWithoutMap(FrameData& frame, int with_depth, size_t frame_index,
                                    double time, std::unique_lock<std::mutex>& lock,
                                    TrackResult* result) {
  if (with_depth < options.relocalization.min_initial_points) {
    ++stats.lost;
    return;
  }
  const Eigen::Isometry3d pose =
      have_good ? last_good_camera_from_world : Eigen::Isometry3d::Identity();
  StartMap(pose, frame, frame_index, time, lock);
  result->status = TrackStatus::kInitialized;
  result->keyframe_id = map_keyframes.back();
  Accept(pose, time, {}, result);
}

Tracker::Impl::PoseEstimate Tracker::Impl::FindPose(const Eigen::Isometry3d& predicted,
                                                    const LocalSet& local, const FrameData& frame,
                                                    double time, Association* association) {
  PoseEstimate estimate;
  if (association->count() >= options.matching.min_matches) {
    estimate = EstimatePose(predicted, true, local, frame, association);
  }
  bool relocalizing = consecutive_lost > 0;
  if (!estimate.ok) {
    ClearMatches(*association);
    estimate = Relocalize(frame, association);
    relocalizing = true;
  }
  // Any pose must be near where the camera was last seen: a pose found after losing track (or
  // against keyframes instead of the motion model), and one from few matches on a repeating
  // pattern (floor tiles below a blank wall), which can jump by metres.
  if (estimate.ok && (!NearLastGoodPose(estimate.camera_from_world, time) ||
                      (relocalizing && !NearMotionModel(estimate.camera_from_world, time)))) {
    ++(relocalizing ? stats.relocalizations_refused : stats.jumps_refused);
    ClearMatches(*association);
    estimate = {};
  }
  return estimate;
}

void Tracker::Impl::TakePose(const PoseEstimate& estimate, const LocalSet& local,
                             const FrameData& frame, Association* association,
                             TrackResult* result) {
  const bool occluded = result->static_depth_share < options.relocalization.min_static_depth_share;
  const bool was_lost = consecutive_lost > 0;
  result->status = occluded   ? TrackStatus::kOccluded
                   : was_lost ? TrackStatus::kRelocalized
                              : TrackStatus::kTracked;
  if (was_lost) ++stats.relocalized;
  if (occluded) ++stats.occluded;
  result->inliers = estimate.inliers;
  weakest_inliers_since_keyframe = std::min(weakest_inliers_since_keyframe, estimate.inliers);
  result->reprojection_rmse_px = estimate.rmse_px;
  CountVisibility(estimate.camera_from_world, local, *association);
  MergeDuplicates(estimate.camera_from_world, frame, association);
  ++frames_since_keyframe;
  consecutive_predicted = 0;
}

void Tracker::Impl::TrackWithoutPose(const Eigen::Isometry3d& predicted, const LocalSet& local,
                                     FrameData& frame, int with_depth, size_t frame_index,
                                     double time, std::unique_lock<std::mutex>& lock,
                                     TrackResult* result) {
  const bool occluded = result->static_depth_share < options.relocalization.min_static_depth_share;
  if (HasPriorMotion()) {  // the given poses carry the frame where vision failed
    ++stats.carried;
    result->status = TrackStatus::kCarried;
    Accept(PriorPrediction(), time, {}, result);
    return;
  }
  if (occluded && have_last &&
      consecutive_predicted < options.relocalization.max_predicted_frames) {
    // Nothing to track behind the occluder: the motion model carries the pose through.
    if (consecutive_predicted == 0) {
      prediction_run = {records.size(), 0, last_good_camera_from_world, last_good_time};
    }
    ++consecutive_predicted;
    ++stats.predicted;
    weakest_inliers_since_keyframe = 0;
    result->status = TrackStatus::kPredicted;
    Accept(predicted, time, {}, result);
    prediction_run.end = records.size();
    return;
  }
  if (!occluded &&
      TrackByRgbdOdometry(predicted, local, frame, with_depth, frame_index, time, lock, result)) {
    return;
  }
  ++consecutive_lost;
  ++stats.lost;
  if (consecutive_lost == 1) DropUnconfirmedPredictions();
  weakest_inliers_since_keyframe = 0;
  have_last = false;
  if (PastNewMapWait() && with_depth >= options.relocalization.new_map_min_points) {
    StartMap(last_good_camera_from_world, frame, frame_index, time, lock);
    ++stats.new_maps;
    --stats.lost;
    result->status = TrackStatus::kNewMap;
    result->keyframe_id = map_keyframes.back();
    Accept(last_good_camera_from_world, time, {}, result);
  }
}

void Tracker::Impl::CountVisibility(const Eigen::Isometry3d& camera_from_world,
                                    const LocalSet& local, const Association& association) {
  for (const auto& [id, landmark] : local) {
    const Eigen::Vector3d p = camera_from_world * landmark->position;
    if (p.z() < options.matching.min_landmark_depth) continue;
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
  const double distance = CameraDistance(camera_from_world, last_good_camera_from_world);
  const double elapsed_s = std::max(0.0, time - last_good_time);
  return distance <= options.relocalization.relocalization_max_distance_m +
                         options.relocalization.relocalization_max_speed_mps * elapsed_s;
}

bool Tracker::Impl::NearMotionModel(const Eigen::Isometry3d& camera_from_world, double time) const {
  const std::optional<Eigen::Isometry3d> carried = MotionModelPose(time);
  return !carried || CameraDistance(camera_from_world, *carried) <=
                         options.relocalization.motion_model_max_distance_m;
}

// The motion model's poses through an occlusion that ended with the camera lost, not found again,
// were guesses nothing confirmed (a lens covered while the camera was carried: a metre off in
// 0.5 s). They leave the trajectory and count as lost, and the last good pose is the one before.
void Tracker::Impl::DropUnconfirmedPredictions() {
  // The run must end at the last record (records only grow, but here): no pose was taken after it.
  if (prediction_run.end == prediction_run.begin || prediction_run.end != records.size()) return;
  const size_t dropped = prediction_run.end - prediction_run.begin;
  records.resize(prediction_run.begin);
  stats.tracked -= dropped;
  stats.lost += dropped;
  last_good_camera_from_world = prediction_run.last_good_camera_from_world;
  last_good_time = prediction_run.last_good_time;
  prediction_run = {};  // dropped once
}

void Tracker::Impl::Accept(const Eigen::Isometry3d& camera_from_world, double time,
                           const std::vector<int>& matched, TrackResult* result) {
  if (have_last) {
    velocity = camera_from_world * last_camera_from_world.inverse();
    velocity_dt_s = time - last_good_time;
  }
  // Through a short loss the velocity before it still holds (MotionModelPose).
  have_velocity = have_last || MotionModelPose(time).has_value();
  have_last = true;
  last_camera_from_world = camera_from_world;
  have_good = true;
  last_good_camera_from_world = camera_from_world;
  last_good_prior = next_prior;
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
  if (!impl_->have_map) return std::nullopt;
  if (!impl_->have_last) {
    if (!impl_->HasPriorMotion()) return std::nullopt;
    return impl_->PriorPrediction().inverse();
  }
  return impl_->Predict(impl_->last_camera_from_world, impl_->last_good_time).inverse();
}

void Tracker::SetPrior(const std::optional<Eigen::Isometry3d>& given_world_from_camera) {
  const std::lock_guard<std::mutex> lock(impl_->mutex);
  impl_->next_prior = given_world_from_camera;
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

size_t Tracker::ForgetLandmarksFoundMoving(int keyframe_id, const cv::Mat& moving) {
  const std::lock_guard<std::mutex> lock(impl_->mutex);
  return impl_->ForgetLandmarksFoundMoving(keyframe_id, moving);
}

size_t Tracker::pose_corrections() const {
  const std::lock_guard<std::mutex> lock(impl_->mutex);
  return impl_->stats.loops_accepted + impl_->stats.global_bundle_adjustments +
         impl_->stats.segment_moves;
}

void Tracker::MoveKeyframes(const std::map<int, Eigen::Isometry3d>& world_from_keyframe) {
  std::unique_lock<std::mutex> lock(impl_->mutex);
  impl_->TakeLoopCorrection(lock);
  impl_->TakeAdjustment(lock);
  impl_->MoveKeyframes(world_from_keyframe);
}

DepthCorrection Tracker::depth_correction() const {
  const std::lock_guard<std::mutex> lock(impl_->mutex);
  return impl_->stats.depth_correction;
}

TrackerStatistics Tracker::statistics() const {
  const std::lock_guard<std::mutex> lock(impl_->mutex);
  TrackerStatistics stats = impl_->stats;
  stats.landmarks = impl_->landmarks.size();
  stats.place_index_mib = static_cast<double>(impl_->loops.MemoryBytes()) / (1024.0 * 1024.0);
  return stats;
}

}  // namespace stillmap
