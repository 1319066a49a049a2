#include "tracker_impl.h"

namespace stillmap {

void Tracker::Impl::WorkerLoop() {
  std::unique_lock<std::mutex> lock(mutex);
  while (true) {
    wake.wait(lock, [this] { return ba_requested || stopping; });
    if (stopping) break;
    ba_requested = false;
    ba_running = true;
    try {
      RunBundleAdjustment(lock);
    } catch (...) {
      worker_error = std::current_exception();
    }
    ba_running = false;
    UpdateFinal();
    ba_done.notify_all();
  }
  ba_running = false;
  ba_done.notify_all();
}

void Tracker::Impl::RunBundleAdjustment(std::unique_lock<std::mutex>& lock) {
  const size_t count = map_keyframes.size();
  if (count < 2) return;
  const size_t window_first = count > static_cast<size_t>(options.local_window)
                                  ? count - static_cast<size_t>(options.local_window)
                                  : 0;
  BundleAdjustmentProblem problem;
  const bool calibrating =
      options.depth_self_calibration && options.depth_calibration_in_bundle_adjustment &&
      count >= static_cast<size_t>(options.depth_calibration.joint_min_keyframes);
  if (calibrating) {
    problem.depth_correction = stats.depth_correction;
    problem.depth_correction_sigma = options.depth_calibration.coefficient_sigma;
  }
  std::vector<int> keyframe_ids, landmark_ids;
  std::unordered_map<int, int> keyframe_index, landmark_index;
  struct ObservationRef {
    int keyframe_id, feature, landmark_id;
  };
  std::vector<ObservationRef> refs;
  for (size_t k = window_first; k < count; ++k) {
    const int id = map_keyframes[k];
    keyframe_index[id] = static_cast<int>(problem.keyframes.size());
    keyframe_ids.push_back(id);
    problem.keyframes.push_back({keyframes.at(id).camera_from_world, false});
  }
  for (size_t k = window_first; k < count; ++k) {
    for (int id : keyframes.at(map_keyframes[k]).landmark_of_feature) {
      if (id < 0 || landmark_index.count(id) > 0) continue;
      landmark_index[id] = static_cast<int>(problem.landmarks.size());
      landmark_ids.push_back(id);
      problem.landmarks.push_back(landmarks.at(id).position);
    }
  }
  bool any_fixed = false;
  for (size_t l = 0; l < landmark_ids.size(); ++l) {
    for (const auto& [keyframe_id, feature] : landmarks.at(landmark_ids[l]).observations) {
      auto it = keyframe_index.find(keyframe_id);
      if (it == keyframe_index.end()) {
        it = keyframe_index.emplace(keyframe_id, static_cast<int>(problem.keyframes.size())).first;
        keyframe_ids.push_back(keyframe_id);
        problem.keyframes.push_back({keyframes.at(keyframe_id).camera_from_world, true});
        any_fixed = true;
      }
      const Keyframe& keyframe = keyframes.at(keyframe_id);
      problem.observations.push_back(
          {it->second, static_cast<int>(l),
           Observation(keyframe.features, static_cast<size_t>(feature), calibrating)});
      refs.push_back({keyframe_id, feature, landmark_ids[l]});
    }
  }
  if (!any_fixed) problem.keyframes[0].fixed = true;  // the gauge
  running_window_first = map_keyframes[window_first];
  std::vector<bool> fixed;
  for (const BundleAdjustmentKeyframe& keyframe : problem.keyframes)
    fixed.push_back(keyframe.fixed);

  lock.unlock();
  const Clock::time_point start = Clock::now();
  BundleAdjustmentResult result;
  try {
    result = SolveWindow(std::move(problem));
  } catch (...) {
    lock.lock();
    running_window_first = INT_MAX;
    throw;
  }
  const double elapsed_ms = MillisecondsSince(start);
  lock.lock();
  running_window_first = INT_MAX;

  if (result.depth_correction) {
    stats.depth_correction = *result.depth_correction;
    ++stats.depth_calibrations;
  } else if (calibrating) {
    ++stats.depth_calibrations_refused;
  }
  // Write back what still exists (tracking may have culled landmarks meanwhile).
  for (size_t k = 0; k < keyframe_ids.size(); ++k) {
    if (fixed[k]) continue;
    const auto it = keyframes.find(keyframe_ids[k]);
    if (it != keyframes.end()) it->second.camera_from_world = result.camera_from_world[k];
  }
  for (size_t l = 0; l < landmark_ids.size(); ++l) {
    const auto it = landmarks.find(landmark_ids[l]);
    if (it != landmarks.end()) it->second.position = result.landmarks[l];
  }
  for (size_t o = 0; o < refs.size(); ++o) {
    if (!result.outlier[o]) continue;
    const ObservationRef& ref = refs[o];
    const auto landmark = landmarks.find(ref.landmark_id);
    if (landmark == landmarks.end()) continue;
    auto& observations = landmark->second.observations;
    observations.erase(std::remove(observations.begin(), observations.end(),
                                   std::make_pair(ref.keyframe_id, ref.feature)),
                       observations.end());
    const auto keyframe = keyframes.find(ref.keyframe_id);
    if (keyframe != keyframes.end()) {
      int& slot = keyframe->second.landmark_of_feature[static_cast<size_t>(ref.feature)];
      if (slot == ref.landmark_id) slot = -1;
    }
    ++stats.observations_rejected;
    if (observations.empty()) EraseLandmark(ref.landmark_id);
  }
  ++stats.bundle_adjustments;
  stats.bundle_adjustment_ms += elapsed_ms;
}

BundleAdjustmentResult Tracker::Impl::SolveWindow(BundleAdjustmentProblem problem) const {
  if (!problem.depth_correction) return SolveBundleAdjustment(problem, options.bundle_adjustment);
  // Jointly with the depth correction; taken only when the window shows the sensor's error
  // clearly (significant, every direction pinned down, within bounds). Otherwise the estimate
  // would mostly be pose error and noise bent into the depth: solved again without it.
  BundleAdjustmentResult joint = SolveBundleAdjustment(problem, options.bundle_adjustment);
  const DepthCorrectionFitOptions& limits = options.depth_calibration;
  if (joint.depth_correction_significance >= limits.joint_min_significance &&
      joint.depth_correction_weakest_sd <= limits.joint_max_weakest_sd &&
      joint.depth_correction->WithinBounds(image_outline, limits.max_delta)) {
    return joint;
  }
  const DepthCorrection current = *problem.depth_correction;
  for (BundleAdjustmentObservation& observation : problem.observations) {
    const Eigen::Vector2d& n = observation.observation.normalized;
    observation.observation.depth_m *= current.Factor(n.x(), n.y());
  }
  problem.depth_correction.reset();
  return SolveBundleAdjustment(problem, options.bundle_adjustment);
}

void Tracker::Impl::RethrowWorkerError() {
  if (worker_error) {
    std::exception_ptr error = worker_error;
    worker_error = nullptr;
    std::rethrow_exception(error);
  }
}

}  // namespace stillmap
