#include "stillmap/tracking/pose_graph.h"

#include <ceres/ceres.h>

#include <algorithm>
#include <stdexcept>

namespace stillmap {
namespace {

// The residual of one edge: the measured relative pose against the one the two nodes give, as
// translation error [m] and rotation error (twice the quaternion's vector part, about the angle
// [rad]), each divided by its standard deviation.
struct RelativePoseCost {
  RelativePoseCost(const Eigen::Isometry3d& from_from_to, double translation_weight,
                   double rotation_weight)
      : measured_translation(from_from_to.translation()),
        measured_rotation(Eigen::Quaterniond(from_from_to.linear()).normalized()),
        translation_scale(translation_weight),
        rotation_scale(rotation_weight) {}

  template <typename T>
  bool operator()(const T* q_from, const T* p_from, const T* q_to, const T* p_to,
                  T* residual) const {
    const Eigen::Map<const Eigen::Quaternion<T>> rotation_from(q_from), rotation_to(q_to);
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> position_from(p_from), position_to(p_to);
    const Eigen::Quaternion<T> inverse_from = rotation_from.conjugate();
    const Eigen::Matrix<T, 3, 1> translation = inverse_from * (position_to - position_from);
    const Eigen::Quaternion<T> rotation = inverse_from * rotation_to;
    const Eigen::Quaternion<T> error = measured_rotation.cast<T>().conjugate() * rotation;
    Eigen::Map<Eigen::Matrix<T, 6, 1>> r(residual);
    r.template head<3>() = (translation - measured_translation.cast<T>()) * T(translation_scale);
    r.template tail<3>() = T(2.0) * error.vec() * T(rotation_scale);
    return true;
  }

  Eigen::Vector3d measured_translation;
  Eigen::Quaterniond measured_rotation;
  double translation_scale, rotation_scale;
};

}  // namespace

PoseGraphEdge EdgeBetween(int from, int to, const Eigen::Isometry3d& world_from_from,
                          const Eigen::Isometry3d& world_from_to, double weight) {
  return {from, to, world_from_from.inverse() * world_from_to, weight};
}

double OdometryEdgeWeight(int weakest_inliers, int full_weight_inliers, double min_weight) {
  if (weakest_inliers >= full_weight_inliers) return 1.0;
  const double share =
      static_cast<double>(std::max(weakest_inliers, 0)) / static_cast<double>(full_weight_inliers);
  return std::max(share * share, min_weight);
}

PoseGraphResult SolvePoseGraph(const PoseGraphProblem& problem, const PoseGraphOptions& options) {
  const size_t n = problem.world_from_node.size();
  if (problem.fixed.size() != n) throw std::invalid_argument("pose graph: one 'fixed' per node");
  bool any_fixed = false;
  for (const bool fixed : problem.fixed) any_fixed = any_fixed || fixed;
  if (n > 0 && !any_fixed) throw std::invalid_argument("pose graph: no node is fixed");
  std::vector<Eigen::Quaterniond> rotations(n);
  std::vector<Eigen::Vector3d> positions(n);
  for (size_t i = 0; i < n; ++i) {
    rotations[i] = Eigen::Quaterniond(problem.world_from_node[i].linear()).normalized();
    positions[i] = problem.world_from_node[i].translation();
  }
  ceres::Problem::Options problem_options;
  problem_options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem ceres_problem(problem_options);
  ceres::EigenQuaternionManifold quaternion;
  for (const PoseGraphEdge& edge : problem.edges) {
    if (edge.from < 0 || edge.to < 0 || static_cast<size_t>(edge.from) >= n ||
        static_cast<size_t>(edge.to) >= n || edge.from == edge.to) {
      throw std::invalid_argument("pose graph: an edge names a missing node");
    }
    const double w = std::sqrt(edge.weight);
    const double w_rotation = std::sqrt(edge.weight * edge.rotation_share);
    auto* cost = new ceres::AutoDiffCostFunction<RelativePoseCost, 6, 4, 3, 4, 3>(
        new RelativePoseCost(edge.from_from_to, w / options.translation_sigma_m,
                             w_rotation / options.rotation_sigma_rad));
    const auto from = static_cast<size_t>(edge.from), to = static_cast<size_t>(edge.to);
    ceres_problem.AddResidualBlock(cost, nullptr, rotations[from].coeffs().data(),
                                   positions[from].data(), rotations[to].coeffs().data(),
                                   positions[to].data());
  }
  for (size_t i = 0; i < n; ++i) {
    double* rotation = rotations[i].coeffs().data();
    if (!ceres_problem.HasParameterBlock(rotation)) continue;
    ceres_problem.SetManifold(rotation, &quaternion);
    if (problem.fixed[i]) {
      ceres_problem.SetParameterBlockConstant(rotation);
      ceres_problem.SetParameterBlockConstant(positions[i].data());
    }
  }
  PoseGraphResult result;
  if (ceres_problem.NumResidualBlocks() > 0) {
    ceres::Solver::Options solver_options;
    solver_options.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
    solver_options.max_num_iterations = options.iterations;
    solver_options.num_threads = 1;
    solver_options.logging_type = ceres::SILENT;
    ceres::Solver::Summary summary;
    ceres::Solve(solver_options, &ceres_problem, &summary);
    result.initial_cost = summary.initial_cost;
    result.final_cost = summary.final_cost;
    result.converged = summary.termination_type == ceres::CONVERGENCE;
  }
  for (size_t i = 0; i < n; ++i) {
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.linear() = rotations[i].normalized().toRotationMatrix();
    pose.translation() = positions[i];
    result.world_from_node.push_back(pose);
  }
  return result;
}

}  // namespace stillmap
