#include "merge_graph.h"

#include <algorithm>
#include <deque>

namespace stillmap {
namespace {

// Which sessions the joined pairs reach from session 0, and where each lies in its frame.
void Reach(const std::vector<PairLinks>& pairs, JoinedSessions* joined) {
  joined->included[0] = true;
  std::deque<size_t> open = {0};
  while (!open.empty()) {
    const size_t at = open.front();
    open.pop_front();
    for (const PairLinks& pair : pairs) {
      if (!pair.joined) continue;
      const auto a = static_cast<size_t>(pair.session_a), b = static_cast<size_t>(pair.session_b);
      if (a == at && !joined->included[b]) {
        joined->first_from_session[b] = joined->first_from_session[a] * pair.a_map_from_b_map;
      } else if (b == at && !joined->included[a]) {
        joined->first_from_session[a] =
            joined->first_from_session[b] * pair.a_map_from_b_map.inverse();
      } else {
        continue;
      }
      const size_t reached = a == at ? b : a;
      joined->included[reached] = true;
      open.push_back(reached);
    }
  }
}

// A session's own edges: each keyframe to the next and to up to `neighbour_edges` later ones
// within neighbour_radius_m, from the session's final poses.
void AddSessionEdges(const SessionRecord& record, int first_node, const MergeOptions& options,
                     std::vector<PoseGraphEdge>* edges) {
  const std::vector<SessionKeyframe>& keyframes = record.keyframes;
  for (size_t k = 0; k < keyframes.size(); ++k) {
    std::vector<std::pair<double, size_t>> near;
    for (size_t j = k + 2; j < keyframes.size(); ++j) {
      const double distance =
          (keyframes[j].map_from_camera.translation() - keyframes[k].map_from_camera.translation())
              .norm();
      if (distance <= options.neighbour_radius_m) near.emplace_back(distance, j);
    }
    std::sort(near.begin(), near.end());
    near.resize(std::min(near.size(), static_cast<size_t>(options.neighbour_edges)));
    if (k + 1 < keyframes.size()) near.emplace_back(0.0, k + 1);
    for (const auto& [distance, j] : near) {
      edges->push_back(EdgeBetween(first_node + static_cast<int>(k),
                                   first_node + static_cast<int>(j), keyframes[k].map_from_camera,
                                   keyframes[j].map_from_camera));
    }
  }
}

}  // namespace

JoinedSessions JoinSessions(const std::vector<MergeSession>& sessions,
                            const std::vector<PairLinks>& pairs, const MergeOptions& options,
                            const PoseGraphOptions& graph_options) {
  JoinedSessions joined;
  joined.included.assign(sessions.size(), false);
  joined.first_from_session.assign(sessions.size(), Eigen::Isometry3d::Identity());
  joined.first_from_keyframe.resize(sessions.size());
  Reach(pairs, &joined);
  PoseGraphProblem problem;
  std::vector<int> first_node(sessions.size(), -1);
  for (size_t s = 0; s < sessions.size(); ++s) {
    if (!joined.included[s]) continue;
    first_node[s] = static_cast<int>(problem.world_from_node.size());
    for (const SessionKeyframe& keyframe : sessions[s].record().keyframes) {
      problem.world_from_node.push_back(joined.first_from_session[s] * keyframe.map_from_camera);
      problem.fixed.push_back(problem.world_from_node.size() == 1);
    }
    AddSessionEdges(sessions[s].record(), first_node[s], options, &problem.edges);
  }
  for (const PairLinks& pair : pairs) {
    const int a = first_node[static_cast<size_t>(pair.session_a)];
    const int b = first_node[static_cast<size_t>(pair.session_b)];
    if (!pair.joined || a < 0 || b < 0) continue;
    for (const SessionLink& link : pair.agreeing) {
      problem.edges.push_back(
          {a + link.keyframe_a, b + link.keyframe_b, link.a_from_b, options.link_weight});
      ++joined.links;
    }
  }
  const PoseGraphResult solved = SolvePoseGraph(problem, graph_options);
  joined.initial_cost = solved.initial_cost;
  joined.final_cost = solved.final_cost;
  joined.converged = solved.converged;
  for (size_t s = 0; s < sessions.size(); ++s) {
    if (first_node[s] < 0) continue;
    const auto begin = solved.world_from_node.begin() + first_node[s];
    joined.first_from_keyframe[s].assign(
        begin, begin + static_cast<std::ptrdiff_t>(sessions[s].record().keyframes.size()));
  }
  return joined;
}

Eigen::Isometry3d CorrectedPose(const SessionRecord& session,
                                const std::vector<Eigen::Isometry3d>& first_from_keyframe,
                                double time, const Eigen::Isometry3d& map_from_camera) {
  const std::vector<SessionKeyframe>& keyframes = session.keyframes;
  auto correction = [&](size_t k) {
    return first_from_keyframe[k] * keyframes[k].map_from_camera.inverse();
  };
  const auto after =
      std::lower_bound(keyframes.begin(), keyframes.end(), time,
                       [](const SessionKeyframe& keyframe, double t) { return keyframe.time < t; });
  if (after == keyframes.begin()) return correction(0) * map_from_camera;
  if (after == keyframes.end()) return correction(keyframes.size() - 1) * map_from_camera;
  const auto k1 = static_cast<size_t>(after - keyframes.begin()), k0 = k1 - 1;
  const double share = (time - keyframes[k0].time) / (keyframes[k1].time - keyframes[k0].time);
  const Eigen::Isometry3d c0 = correction(k0), c1 = correction(k1);
  Eigen::Isometry3d blended = Eigen::Isometry3d::Identity();
  blended.linear() = Eigen::Quaterniond(c0.linear())
                         .slerp(share, Eigen::Quaterniond(c1.linear()))
                         .toRotationMatrix();
  blended.translation() = (1.0 - share) * c0.translation() + share * c1.translation();
  return blended * map_from_camera;
}

}  // namespace stillmap
