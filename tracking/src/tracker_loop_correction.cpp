#include "tracker_impl.h"

namespace stillmap {

void Tracker::Impl::RequestLoopCorrection(int keyframe_id, int candidate,
                                          const Eigen::Isometry3d& camera_from_world,
                                          const Association& association) {
  // Every keyframe is a node, in id order; the oldest holds the gauge.
  LoopCorrection loop;
  PoseGraphProblem& problem = loop.problem;
  std::map<int, int> node_of;
  for (const auto& [id, keyframe] : keyframes) {
    node_of[id] = static_cast<int>(loop.ids.size());
    loop.ids.push_back(id);
    problem.world_from_node.push_back(keyframe.camera_from_world.inverse());
  }
  problem.fixed.assign(loop.ids.size(), false);
  problem.fixed[0] = true;
  for (size_t n = 0; n + 1 < loop.ids.size(); ++n) {
    problem.edges.push_back(EdgeBetween(static_cast<int>(n), static_cast<int>(n + 1),
                                        problem.world_from_node[n],
                                        problem.world_from_node[n + 1]));
  }
  AddCovisibilityEdges(node_of, &problem);
  problem.edges.push_back(EdgeBetween(node_of.at(candidate), node_of.at(keyframe_id),
                                      keyframes.at(candidate).camera_from_world.inverse(),
                                      camera_from_world.inverse()));
  loop.keyframe_id = keyframe_id;
  for (size_t f = 0; f < association.landmark.size(); ++f) {
    if (association.landmark[f] >= 0) loop.merges.emplace_back(f, association.landmark[f]);
  }
  loop.handover_serial = frame_serial + static_cast<size_t>(options.loop_handover_frames);
  pending_loop = std::move(loop);
  if (worker.joinable()) {
    loop_requested = true;
    wake.notify_one();
  } else {
    SolveLoop(pending_loop->problem, &*pending_loop);
    pending_loop->is_solved = true;
  }
}

void Tracker::Impl::SolveLoop(const PoseGraphProblem& problem, LoopCorrection* solved) const {
  const Clock::time_point start = Clock::now();
  try {
    solved->result = SolvePoseGraph(problem, options.pose_graph);
  } catch (...) {
    solved->error = std::current_exception();
  }
  solved->ms = MillisecondsSince(start);
}

void Tracker::Impl::TakeLoopCorrection(std::unique_lock<std::mutex>& lock) {
  if (!pending_loop) return;
  TakeAdjustment(lock);  // solved in the frame before the correction
  if (!pending_loop->is_solved) {
    const Clock::time_point start = Clock::now();
    ba_done.wait(lock, [this] { return pending_loop->is_solved; });
    ++stats.loop_waits;
    stats.loop_wait_ms += MillisecondsSince(start);
  }
  const LoopCorrection loop = std::move(*pending_loop);
  pending_loop.reset();
  if (loop.error) std::rethrow_exception(loop.error);
  stats.loop_solve_ms += loop.ms;
  ApplyLoopCorrection(loop);
  MergeLoopLandmarks(loop);
  ++stats.loops_accepted;
  if (options.loop_global_bundle_adjustment) RequestAdjustment(true);
  UpdateFinal();
}

void Tracker::Impl::ApplyLoopCorrection(const LoopCorrection& loop) {
  // world' = correction * world for each keyframe; keyframes made since the request move with
  // the loop's keyframe, and each landmark with the keyframe that made it.
  std::map<int, Eigen::Isometry3d> correction;
  for (size_t n = 0; n < loop.ids.size(); ++n) {
    correction[loop.ids[n]] =
        loop.result.world_from_node[n] * loop.problem.world_from_node[n].inverse();
  }
  const Eigen::Isometry3d at_loop = correction.at(loop.keyframe_id);
  const int newest = loop.ids.back();
  auto correction_of = [&](int keyframe_id) -> const Eigen::Isometry3d* {
    if (keyframe_id > newest) return &at_loop;
    const auto it = correction.find(keyframe_id);
    return it == correction.end() ? nullptr : &it->second;
  };
  for (auto& [id, keyframe] : keyframes) {
    const Eigen::Isometry3d* moved = correction_of(id);
    if (moved != nullptr)
      keyframe.camera_from_world = keyframe.camera_from_world * moved->inverse();
  }
  for (auto& [id, landmark] : landmarks) {
    const Eigen::Isometry3d* moved = correction_of(landmark.created_keyframe);
    if (moved == nullptr && !landmark.observations.empty()) {
      moved = correction_of(landmark.observations.front().first);
    }
    if (moved != nullptr) landmark.position = *moved * landmark.position;
  }
  stats.loop_correction_m = std::max(stats.loop_correction_m, at_loop.translation().norm());
  stats.loop_correction_deg = std::max(stats.loop_correction_deg,
                                       Eigen::AngleAxisd(at_loop.linear()).angle() * 180.0 / M_PI);
  // The frames tracked since are posed through their keyframes; the motion model's poses move
  // with the newest keyframe (its velocity is relative and stays).
  last_camera_from_world = last_camera_from_world * at_loop.inverse();
  last_good_camera_from_world = last_good_camera_from_world * at_loop.inverse();
}

void Tracker::Impl::MergeLoopLandmarks(const LoopCorrection& loop) {
  // The keyframe's features found in the earlier place: its landmarks are merged into those.
  const auto found = keyframes.find(loop.keyframe_id);
  if (found == keyframes.end()) return;  // culled since
  Keyframe& keyframe = found->second;
  for (const auto& [f, earlier] : loop.merges) {
    if (landmarks.count(earlier) == 0) continue;
    const int own = keyframe.landmark_of_feature[f];
    if (own == earlier) continue;
    if (own >= 0 && landmarks.count(own) > 0) {
      MergeLandmark(std::min(own, earlier), std::max(own, earlier));
      continue;
    }
    Landmark& landmark = landmarks.at(earlier);
    const bool seen = std::any_of(landmark.observations.begin(), landmark.observations.end(),
                                  [&](const auto& o) { return o.first == loop.keyframe_id; });
    if (!seen) {
      landmark.observations.emplace_back(loop.keyframe_id, static_cast<int>(f));
      keyframe.landmark_of_feature[f] = earlier;
    }
  }
}

}  // namespace stillmap
