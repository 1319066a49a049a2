#include "stillmap/io/cpu_usage.h"
#include "tracker_impl.h"

namespace stillmap {

// The worker solves the pending adjustment's problem and nothing else: it reads and writes no
// other state, so what the tracker sees does not depend on when the solve ends.
void Tracker::Impl::WorkerLoop() {
  std::unique_lock<std::mutex> lock(mutex);
  while (true) {
    wake.wait(lock, [this] { return ba_requested || loop_requested || stopping; });
    if (stopping) break;
    if (loop_requested) {
      loop_requested = false;
      LoopCorrection solved;
      solved.problem = pending_loop->problem;
      lock.unlock();
      loops.Solve(&solved);
      lock.lock();
      stats.worker_cpu_ms = ThreadCpuMs();  // the thread's whole CPU time so far
      pending_loop->result = std::move(solved.result);
      pending_loop->error = solved.error;
      pending_loop->ms = solved.ms;
      pending_loop->is_solved = true;
      ba_done.notify_all();
      continue;
    }
    ba_requested = false;
    ba_running = true;
    BundleAdjustmentProblem problem = std::move(pending->problem);
    lock.unlock();
    SolvedWindow solved = Solve(std::move(problem));
    lock.lock();
    stats.worker_cpu_ms = ThreadCpuMs();
    pending->solved = std::move(solved);
    pending->is_solved = true;
    ba_running = false;
    ba_done.notify_all();
  }
  ba_running = false;
  ba_done.notify_all();
}

Tracker::Impl::SolvedWindow Tracker::Impl::Solve(BundleAdjustmentProblem problem) const {
  SolvedWindow solved;
  const Clock::time_point start = Clock::now();
  try {
    solved.result = SolveWindow(std::move(problem));
  } catch (...) {
    solved.error = std::current_exception();
  }
  solved.ms = MillisecondsSince(start);
  return solved;
}

std::optional<Tracker::Impl::WindowAdjustment> Tracker::Impl::PrepareAdjustment(
    size_t window) const {
  const size_t count = map_keyframes.size();
  if (count < 2) return std::nullopt;
  const size_t window_first = count > window ? count - window : 0;
  WindowAdjustment adjustment;
  BundleAdjustmentProblem& problem = adjustment.problem;
  adjustment.calibrating =
      options.matching.depth_self_calibration &&
      options.matching.depth_calibration_in_bundle_adjustment &&
      count >= static_cast<size_t>(options.matching.depth_calibration.joint_min_keyframes);
  if (adjustment.calibrating) {
    problem.depth_correction = stats.depth_correction;
    problem.depth_correction_sigma = options.matching.depth_calibration.coefficient_sigma;
  }
  std::unordered_map<int, int> keyframe_index, landmark_index;
  for (size_t k = window_first; k < count; ++k) {
    const int id = map_keyframes[k];
    keyframe_index[id] = static_cast<int>(problem.keyframes.size());
    adjustment.keyframe_ids.push_back(id);
    problem.keyframes.push_back({keyframes.at(id).camera_from_world, false});
  }
  for (size_t k = window_first; k < count; ++k) {
    for (int id : keyframes.at(map_keyframes[k]).landmark_of_feature) {
      if (id < 0 || landmark_index.count(id) > 0) continue;
      landmark_index[id] = static_cast<int>(problem.landmarks.size());
      adjustment.landmark_ids.push_back(id);
      problem.landmarks.push_back(landmarks.at(id).position);
    }
  }
  bool any_fixed = false;
  for (size_t l = 0; l < adjustment.landmark_ids.size(); ++l) {
    for (const auto& [keyframe_id, feature] :
         landmarks.at(adjustment.landmark_ids[l]).observations) {
      auto it = keyframe_index.find(keyframe_id);
      if (it == keyframe_index.end()) {
        it = keyframe_index.emplace(keyframe_id, static_cast<int>(problem.keyframes.size())).first;
        adjustment.keyframe_ids.push_back(keyframe_id);
        problem.keyframes.push_back({keyframes.at(keyframe_id).camera_from_world, true});
        any_fixed = true;
      }
      const Keyframe& keyframe = keyframes.at(keyframe_id);
      problem.observations.push_back(
          {it->second, static_cast<int>(l),
           Observation(keyframe.features, static_cast<size_t>(feature), adjustment.calibrating)});
      adjustment.refs.push_back({keyframe_id, feature, adjustment.landmark_ids[l]});
    }
  }
  if (!any_fixed) problem.keyframes[0].fixed = true;  // the gauge
  adjustment.window_first = map_keyframes[window_first];
  for (const BundleAdjustmentKeyframe& keyframe : problem.keyframes) {
    adjustment.fixed.push_back(keyframe.fixed);
  }
  return adjustment;
}

bool Tracker::Impl::GlobalAdjustmentRunning() const {
  return pending && pending->global && frame_serial < pending->handover_serial;
}

void Tracker::Impl::RequestAdjustment(bool global) {
  std::optional<WindowAdjustment> adjustment = PrepareAdjustment(
      global ? map_keyframes.size() : static_cast<size_t>(options.local_map.local_window));
  if (!adjustment) return;
  adjustment->global = global;
  adjustment->handover_serial =
      frame_serial +
      static_cast<size_t>(global ? options.loops.global_bundle_adjustment_handover_frames
                                 : options.local_map.bundle_adjustment_handover_frames);
  running_window_first = adjustment->window_first;
  pending = std::move(adjustment);
  if (worker.joinable()) {
    ba_requested = true;
    wake.notify_one();
  } else {
    pending->solved = Solve(std::move(pending->problem));
    pending->is_solved = true;
  }
}

void Tracker::Impl::TakeAdjustment(std::unique_lock<std::mutex>& lock) {
  if (!pending) return;
  if (!pending->is_solved) {
    const Clock::time_point start = Clock::now();
    ba_done.wait(lock, [this] { return pending->is_solved; });
    ++stats.bundle_adjustment_waits;
    stats.bundle_adjustment_wait_ms += MillisecondsSince(start);
  }
  WindowAdjustment adjustment = std::move(*pending);
  pending.reset();
  running_window_first = INT_MAX;
  if (adjustment.solved.error) std::rethrow_exception(adjustment.solved.error);
  ApplyAdjustment(adjustment);
  UpdateFinal();
}

void Tracker::Impl::ApplyAdjustment(const WindowAdjustment& adjustment) {
  const BundleAdjustmentResult& result = adjustment.solved.result;
  if (result.depth_correction) {
    stats.depth_correction = *result.depth_correction;
    ++stats.depth_calibrations;
  } else if (adjustment.calibrating) {
    ++stats.depth_calibrations_refused;
  }
  // Write back what still exists (tracking may have culled landmarks since the request).
  for (size_t k = 0; k < adjustment.keyframe_ids.size(); ++k) {
    if (adjustment.fixed[k]) continue;
    const auto it = keyframes.find(adjustment.keyframe_ids[k]);
    if (it != keyframes.end()) it->second.camera_from_world = result.camera_from_world[k];
  }
  for (size_t l = 0; l < adjustment.landmark_ids.size(); ++l) {
    const auto it = landmarks.find(adjustment.landmark_ids[l]);
    if (it != landmarks.end()) it->second.position = result.landmarks[l];
  }
  for (size_t o = 0; o < adjustment.refs.size(); ++o) {
    if (result.outlier[o]) RejectObservation(adjustment.refs[o]);
  }
  if (adjustment.global) {
    ++stats.global_bundle_adjustments;
    stats.global_bundle_adjustment_ms += adjustment.solved.ms;
  } else {
    ++stats.bundle_adjustments;
    stats.bundle_adjustment_ms += adjustment.solved.ms;
  }
}

void Tracker::Impl::RejectObservation(const ObservationRef& ref) {
  const auto landmark = landmarks.find(ref.landmark_id);
  if (landmark == landmarks.end()) return;
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

BundleAdjustmentResult Tracker::Impl::SolveWindow(BundleAdjustmentProblem problem) const {
  if (!problem.depth_correction) return SolveBundleAdjustment(problem, options.bundle_adjustment);
  // Jointly with the depth correction; taken only when the window shows the sensor's error
  // clearly (significant, every direction pinned down, within bounds). Otherwise the estimate
  // would mostly be pose error and noise bent into the depth: solved again without it.
  BundleAdjustmentResult joint = SolveBundleAdjustment(problem, options.bundle_adjustment);
  const DepthCorrectionFitOptions& limits = options.matching.depth_calibration;
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

}  // namespace stillmap
