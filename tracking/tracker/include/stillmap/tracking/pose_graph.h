// Pose-graph optimisation over keyframe poses (SE(3)), for loop correction: each edge is a
// measured relative pose between two keyframes (odometry and covisibility edges from the poses
// before the loop, loop edges from the verified place match), and the solve spreads the loop's
// error over the keyframes between its two ends. Solved with Ceres (automatic derivatives,
// quaternion manifold, sparse Cholesky, one thread: the result does not depend on the machine's
// load).
#pragma once

#include <Eigen/Geometry>
#include <vector>

namespace stillmap {

struct PoseGraphOptions {
  int iterations = 50;
  // Edge noise: the standard deviation of a relative pose's translation [m] and rotation [rad].
  // Odometry and covisibility edges come from poses the local bundle adjustment had settled.
  double translation_sigma_m = 0.01;
  double rotation_sigma_rad = 0.005;

  template <typename Self, typename Visitor>
  static void VisitFields(Self& self, Visitor& visit) {
    visit("iterations", self.iterations, "pose graph solver iterations at most");
    visit("translation_sigma_m", self.translation_sigma_m,
          "pose graph edges: translation noise [m]");
    visit("rotation_sigma_rad", self.rotation_sigma_rad, "pose graph edges: rotation noise [rad]");
  }
};

struct PoseGraphEdge {
  int from = 0, to = 0;  // node indices
  // The measured pose of `to` in the frame of `from` (from_from_to = world_from_from^-1 *
  // world_from_to).
  Eigen::Isometry3d from_from_to = Eigen::Isometry3d::Identity();
  double weight = 1.0;          // scales the information of the edge
  double rotation_share = 1.0;  // its rotation's information is weight times this
};

struct PoseGraphProblem {
  std::vector<Eigen::Isometry3d> world_from_node;  // initial poses
  std::vector<bool> fixed;                         // per node: held where it is
  std::vector<PoseGraphEdge> edges;
};

struct PoseGraphResult {
  std::vector<Eigen::Isometry3d> world_from_node;
  double initial_cost = 0.0, final_cost = 0.0;
  bool converged = false;
};

// Throws std::invalid_argument on edges that name missing nodes or a graph with no fixed node.
PoseGraphResult SolvePoseGraph(const PoseGraphProblem& problem, const PoseGraphOptions& options);

// The edge that measures `to` in the frame of `from` as the two poses have it now.
PoseGraphEdge EdgeBetween(int from, int to, const Eigen::Isometry3d& world_from_from,
                          const Eigen::Isometry3d& world_from_to, double weight = 1.0);

// The weight of an odometry edge whose frames had at fewest `weakest_inliers` inliers (0: one
// was lost or posed by the motion model): 1 from `full_weight_inliers` on, (weakest / that)^2
// below, never less than `min_weight`.
double OdometryEdgeWeight(int weakest_inliers, int full_weight_inliers, double min_weight);

}  // namespace stillmap
