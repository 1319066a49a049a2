// The sessions joined into the first session's map frame: which sessions the verified links
// reach from the first, and one pose graph over all their keyframes.
#pragma once

#include <Eigen/Geometry>
#include <vector>

#include "merge_links.h"
#include "merge_sessions.h"
#include "stillmap/pipeline/merge_options.h"
#include "stillmap/tracking/pose_graph.h"

namespace stillmap {

struct JoinedSessions {
  std::vector<bool> included;  // per session: reached from the first by joined pairs
  // Per session: its map frame in the first session's, as the links placed it before the pose
  // graph (the identity for the first).
  std::vector<Eigen::Isometry3d> first_from_session;
  // Per session and keyframe (of its record): the pose after the pose graph, in the first
  // session's map frame (empty for sessions left out).
  std::vector<std::vector<Eigen::Isometry3d>> first_from_keyframe;
  double initial_cost = 0.0, final_cost = 0.0;
  bool converged = false;
  size_t links = 0;  // link edges of the pose graph
};

// Joins what the links of `pairs` reach from session 0. The first session's first keyframe is
// held where it is, so the merged map keeps its map frame.
JoinedSessions JoinSessions(const std::vector<MergeSession>& sessions,
                            const std::vector<PairLinks>& pairs, const MergeOptions& options,
                            const PoseGraphOptions& graph_options);

// The pose of a frame of `session` at `time` (its pose `map_from_camera` in its own map frame)
// in the first session's frame: moved with the correction of its keyframes, interpolated between
// the two around it in time (the nearest one outside them).
Eigen::Isometry3d CorrectedPose(const SessionRecord& session,
                                const std::vector<Eigen::Isometry3d>& first_from_keyframe,
                                double time, const Eigen::Isometry3d& map_from_camera);

}  // namespace stillmap
