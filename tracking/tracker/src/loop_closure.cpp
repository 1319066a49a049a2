#include "stillmap/tracking/loop_closure.h"

#include <algorithm>
#include <chrono>
#include <climits>
#include <cmath>

#include "stillmap/io/timing.h"
#include "stillmap/io/trajectory.h"

namespace stillmap {

LoopClosure::LoopClosure(const LoopClosureOptions& options, std::uint64_t seed)
    : options_(options), places_(options.place, seed) {}

std::vector<int> LoopClosure::RelocalizationCandidates(const cv::Mat& descriptors) const {
  std::vector<int> out;
  for (const PlaceCandidate& candidate :
       places_.Query(descriptors, static_cast<size_t>(options_.place_candidates),
                     [](int) { return false; })) {
    if (candidate.votes >= options_.place_min_votes) out.push_back(candidate.keyframe_id);
  }
  return out;
}

bool LoopClosure::PlausibleDrift(double path_m, const Eigen::Isometry3d& correction) const {
  const double angle_deg = RotationAngleDeg(correction);
  return correction.translation().norm() <=
             options_.loop_max_drift_m + options_.loop_max_drift_share * path_m &&
         angle_deg <= options_.loop_max_drift_deg + options_.loop_max_drift_deg_per_m * path_m;
}

bool LoopClosure::AcceptVerified(int verified, bool same_place_as_last) {
  if (verified < 0) {
    streak_ = 0;
    return false;
  }
  streak_ = same_place_as_last ? streak_ + 1 : 1;
  last_candidate_ = verified;
  if (streak_ < options_.loop_consistency) return false;
  streak_ = 0;
  return true;
}

LoopCorrection LoopClosure::PrepareCorrection(
    const std::map<int, Eigen::Isometry3d>& world_from_keyframe,
    const std::map<int, int>& weakest_inliers,
    const std::map<std::pair<int, int>, int>& shared_pairs, int keyframe_id, int candidate,
    const Eigen::Isometry3d& world_from_loop_pose) const {
  // Every keyframe is a node, in id order; the oldest holds the gauge.
  LoopCorrection loop;
  PoseGraphProblem& problem = loop.problem;
  std::map<int, int> node_of;
  for (const auto& [id, world_from_camera] : world_from_keyframe) {
    node_of[id] = static_cast<int>(loop.ids.size());
    loop.ids.push_back(id);
    problem.world_from_node.push_back(world_from_camera);
  }
  problem.fixed.assign(loop.ids.size(), false);
  problem.fixed[0] = true;
  for (size_t n = 0; n + 1 < loop.ids.size(); ++n) {
    const auto weakest = weakest_inliers.find(loop.ids[n + 1]);
    problem.edges.push_back(
        EdgeBetween(static_cast<int>(n), static_cast<int>(n + 1), problem.world_from_node[n],
                    problem.world_from_node[n + 1],
                    OdometryWeight(weakest == weakest_inliers.end() ? INT_MAX : weakest->second)));
  }
  for (const auto& [pair, count] : shared_pairs) {  // covisibility, beside the odometry chain
    if (count < options_.pose_graph_min_shared) continue;
    const auto from = node_of.find(pair.first), to = node_of.find(pair.second);
    if (from == node_of.end() || to == node_of.end() || to->second == from->second + 1) continue;
    problem.edges.push_back(EdgeBetween(from->second, to->second,
                                        problem.world_from_node[static_cast<size_t>(from->second)],
                                        problem.world_from_node[static_cast<size_t>(to->second)]));
  }
  problem.edges.push_back(EdgeBetween(node_of.at(candidate), node_of.at(keyframe_id),
                                      world_from_keyframe.at(candidate), world_from_loop_pose));
  loop.keyframe_id = keyframe_id;
  loop.candidate = candidate;
  return loop;
}

double LoopClosure::OdometryWeight(int weakest_inliers) const {
  return OdometryEdgeWeight(weakest_inliers, options_.pose_graph_full_weight_inliers,
                            options_.pose_graph_min_weight);
}

void LoopClosure::Solve(LoopCorrection* correction) const {
  const auto start = std::chrono::steady_clock::now();
  try {
    correction->result = SolvePoseGraph(correction->problem, options_.pose_graph);
  } catch (...) {
    correction->error = std::current_exception();
  }
  correction->ms = MillisecondsSince(start);
}

std::map<int, Eigen::Isometry3d> LoopClosure::Corrections(const LoopCorrection& loop) {
  std::map<int, Eigen::Isometry3d> correction;
  for (size_t n = 0; n < loop.ids.size(); ++n) {
    correction[loop.ids[n]] =
        loop.result.world_from_node[n] * loop.problem.world_from_node[n].inverse();
  }
  return correction;
}

}  // namespace stillmap
