#include "stillmap/tracking/bundle_adjustment.h"

#include <ceres/ceres.h>
#include <ceres/normal_prior.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <array>
#include <cmath>

#include "pose_manifold.h"

namespace stillmap {
namespace {

using internal::PoseFromParameters;
using internal::PoseManifold;
using internal::PoseToParameters;

double ChiSquareThreshold(const RgbdObservation& observation,
                          const BundleAdjustmentOptions& options) {
  return observation.depth_m > 0.0 ? options.chi2_with_depth : options.chi2_without_depth;
}

// The observation with its raw depth corrected by `coefficients` (null: taken as it is).
RgbdObservation Corrected(const RgbdObservation& observation, const double* coefficients) {
  if (coefficients == nullptr || !(observation.depth_m > 0.0)) return observation;
  DepthCorrection correction;
  std::copy(coefficients, coefficients + 5, correction.coefficients.begin());
  RgbdObservation corrected = observation;
  corrected.depth_m *= correction.Factor(observation.normalized.x(), observation.normalized.y());
  return corrected;
}

// One observation: parameters [pose (7)], [landmark (3)] and, for the joint depth calibration,
// [depth correction (5)] applied to the raw depth. The landmark Jacobian is the residual's
// derivative with respect to the point in the camera frame (the translation columns of the pose
// Jacobian) times the rotation. With d = raw (1 + p . phi), the depth row r = w (1/Z - 1/d) has
// dr/dp = w raw phi / d^2.
class BundleCost : public ceres::CostFunction {
 public:
  BundleCost(const RgbdObservation& observation, bool calibrating)
      : observation_(observation), calibrating_(calibrating) {
    set_num_residuals(3);
    *mutable_parameter_block_sizes() = {7, 3};
    if (calibrating) mutable_parameter_block_sizes()->push_back(5);
  }

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    const Eigen::Isometry3d camera_from_world = PoseFromParameters(parameters[0]);
    const Eigen::Map<const Eigen::Vector3d> point(parameters[1]);
    const RgbdObservation observation =
        Corrected(observation_, calibrating_ ? parameters[2] : nullptr);
    if (calibrating_ && observation_.depth_m > 0.0 && !(observation.depth_m > 0.0)) return false;
    const bool want_jacobian = jacobians != nullptr;
    Eigen::Vector3d r;
    Eigen::Matrix<double, 3, 6> j;
    if (!EvaluateRgbdResidual(camera_from_world, point, observation, &r,
                              want_jacobian ? &j : nullptr)) {
      return false;
    }
    Eigen::Map<Eigen::Vector3d> residual_out(residuals);
    residual_out = r;
    if (want_jacobian && jacobians[0] != nullptr) {
      Eigen::Map<Eigen::Matrix<double, 3, 7, Eigen::RowMajor>> out(jacobians[0]);
      out.leftCols<6>() = j;
      out.col(6).setZero();
    }
    if (want_jacobian && jacobians[1] != nullptr) {
      Eigen::Map<Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> out(jacobians[1]);
      out = j.rightCols<3>() * camera_from_world.linear();
    }
    if (want_jacobian && calibrating_ && jacobians[2] != nullptr) {
      Eigen::Map<Eigen::Matrix<double, 3, 5, Eigen::RowMajor>> out(jacobians[2]);
      out.setZero();
      if (observation.depth_m > 0.0) {
        const Eigen::Vector2d& n = observation_.normalized;
        const double d = observation.depth_m;
        out.row(2) = (observation_.depth_m / (observation.sigma_inverse_depth * d * d)) *
                     DepthCorrection::Basis(n.x(), n.y()).transpose();
      }
    }
    return true;
  }

 private:
  RgbdObservation observation_;  // depth raw when calibrating
  bool calibrating_;
};

// How well the observations pin the depth correction down: the information matrix of its
// coefficients with each landmark's depth marginalized out (the part of the correction common to
// all the views of a landmark moves the landmark instead). Pose coupling is left out.
Eigen::Matrix<double, 5, 5> CorrectionInformation(const BundleAdjustmentProblem& problem,
                                                  const std::vector<bool>& outlier,
                                                  const double* coefficients) {
  struct Sums {
    double a = 0.0;
    Eigen::Matrix<double, 5, 1> a_phi = Eigen::Matrix<double, 5, 1>::Zero();
    Eigen::Matrix<double, 5, 5> a_phi_phi = Eigen::Matrix<double, 5, 5>::Zero();
  };
  std::vector<Sums> per_landmark(problem.landmarks.size());
  for (size_t o = 0; o < problem.observations.size(); ++o) {
    const BundleAdjustmentObservation& observation = problem.observations[o];
    const RgbdObservation& raw = observation.observation;
    if (outlier[o] || !(raw.depth_m > 0.0)) continue;
    const double d = Corrected(raw, coefficients).depth_m;
    if (!(d > 0.0)) continue;
    const Eigen::Matrix<double, 5, 1> phi =
        DepthCorrection::Basis(raw.normalized.x(), raw.normalized.y());
    const double gain = raw.depth_m / (raw.sigma_inverse_depth * d * d);
    Sums& sums = per_landmark[static_cast<size_t>(observation.landmark)];
    sums.a += gain * gain;
    sums.a_phi += gain * gain * phi;
    sums.a_phi_phi += gain * gain * phi * phi.transpose();
  }
  Eigen::Matrix<double, 5, 5> information = Eigen::Matrix<double, 5, 5>::Zero();
  for (const Sums& sums : per_landmark) {
    if (sums.a <= 0.0) continue;
    information += sums.a_phi_phi - sums.a_phi * sums.a_phi.transpose() / sums.a;
  }
  return information;
}

// The solver's parameter blocks: 7 per pose (quaternion, translation), 3 per point, and the
// depth correction's 5 coefficients (`correction` null when it is not estimated).
struct Parameters {
  std::vector<double> poses, points;
  std::array<double, 5> coefficients{};
  double* correction = nullptr;
};

Parameters ParametersOf(const BundleAdjustmentProblem& problem) {
  Parameters parameters;
  parameters.poses.resize(7 * problem.keyframes.size());
  for (size_t k = 0; k < problem.keyframes.size(); ++k) {
    PoseToParameters(problem.keyframes[k].camera_from_world, &parameters.poses[7 * k]);
  }
  parameters.points.resize(3 * problem.landmarks.size());
  for (size_t i = 0; i < problem.landmarks.size(); ++i) {
    Eigen::Map<Eigen::Vector3d> point(&parameters.points[3 * i]);
    point = problem.landmarks[i];
  }
  if (problem.depth_correction.has_value()) {
    parameters.coefficients = problem.depth_correction->coefficients;
    parameters.correction = parameters.coefficients.data();
  }
  return parameters;
}

// One residual block per observation not marked an outlier; the number added. Round one is
// robust (Huber); round two runs on the inliers only, like ORB-SLAM2.
int AddObservations(const BundleAdjustmentProblem& problem, const BundleAdjustmentOptions& options,
                    int round, const std::vector<bool>& outlier, Parameters& parameters,
                    ceres::Problem* ceres_problem) {
  int residual_count = 0;
  for (size_t o = 0; o < problem.observations.size(); ++o) {
    if (outlier[o]) continue;
    const BundleAdjustmentObservation& observation = problem.observations[o];
    double* pose = &parameters.poses[7 * static_cast<size_t>(observation.keyframe)];
    double* point = &parameters.points[3 * static_cast<size_t>(observation.landmark)];
    ceres::LossFunction* loss =
        round == 0
            ? new ceres::HuberLoss(std::sqrt(ChiSquareThreshold(observation.observation, options)))
            : nullptr;
    auto* cost = new BundleCost(observation.observation, parameters.correction != nullptr);
    if (parameters.correction != nullptr) {
      ceres_problem->AddResidualBlock(cost, loss, pose, point, parameters.correction);
    } else {
      ceres_problem->AddResidualBlock(cost, loss, pose, point);
    }
    ++residual_count;
  }
  return residual_count;
}

// Every observation classified against the current estimate.
void ClassifyObservations(const BundleAdjustmentProblem& problem,
                          const BundleAdjustmentOptions& options, const Parameters& parameters,
                          std::vector<bool>* outlier) {
  for (size_t o = 0; o < problem.observations.size(); ++o) {
    const BundleAdjustmentObservation& observation = problem.observations[o];
    const Eigen::Isometry3d camera_from_world =
        PoseFromParameters(&parameters.poses[7 * static_cast<size_t>(observation.keyframe)]);
    const Eigen::Map<const Eigen::Vector3d> point(
        &parameters.points[3 * static_cast<size_t>(observation.landmark)]);
    const RgbdObservation corrected = Corrected(observation.observation, parameters.correction);
    Eigen::Vector3d r;
    (*outlier)[o] = !EvaluateRgbdResidual(camera_from_world, point, corrected, &r, nullptr) ||
                    r.squaredNorm() > ChiSquareThreshold(observation.observation, options);
  }
}

// The poses, points and depth correction solved for, with how well the data pins the correction.
void ReadResult(const BundleAdjustmentProblem& problem, Parameters& parameters,
                BundleAdjustmentResult* result) {
  result->camera_from_world.reserve(problem.keyframes.size());
  for (size_t k = 0; k < problem.keyframes.size(); ++k) {
    result->camera_from_world.push_back(PoseFromParameters(&parameters.poses[7 * k]));
  }
  if (parameters.correction != nullptr) {
    result->depth_correction = DepthCorrection{parameters.coefficients};
    const Eigen::Matrix<double, 5, 5> information =
        CorrectionInformation(problem, result->outlier, parameters.correction);
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 5, 5>> eigen(information);
    const double weakest = std::max(eigen.eigenvalues()(0), 1e-300);
    result->depth_correction_weakest_sd = 1.0 / std::sqrt(weakest);
    Eigen::Map<const Eigen::Matrix<double, 5, 1>> p(parameters.coefficients.data());
    result->depth_correction_significance = p.dot(information * p);
  }
  result->landmarks.reserve(problem.landmarks.size());
  for (size_t i = 0; i < problem.landmarks.size(); ++i) {
    result->landmarks.emplace_back(Eigen::Map<const Eigen::Vector3d>(&parameters.points[3 * i]));
  }
}

// The keyframes to hold: the fixed ones, and those with fewer than min_keyframe_observations
// observations not (yet) found outliers. A held keyframe is back at its pose.
std::vector<bool> HeldKeyframes(const BundleAdjustmentProblem& problem,
                                const BundleAdjustmentOptions& options,
                                const std::vector<bool>& outlier, Parameters* parameters) {
  std::vector<int> seen(problem.keyframes.size(), 0);
  for (size_t o = 0; o < problem.observations.size(); ++o) {
    if (!outlier[o]) ++seen[static_cast<size_t>(problem.observations[o].keyframe)];
  }
  std::vector<bool> held(problem.keyframes.size(), false);
  for (size_t k = 0; k < problem.keyframes.size(); ++k) {
    held[k] = problem.keyframes[k].fixed || seen[k] < options.min_keyframe_observations;
    if (held[k])
      PoseToParameters(problem.keyframes[k].camera_from_world, &parameters->poses[7 * k]);
  }
  return held;
}

// The poses' manifold, the held ones constant; returns how many are free.
int SetUpPoses(const std::vector<bool>& held, Parameters* parameters,
               ceres::Problem* ceres_problem) {
  static PoseManifold manifold;
  int free_poses = 0;
  for (size_t k = 0; k < held.size(); ++k) {
    double* pose = &parameters->poses[7 * k];
    if (!ceres_problem->HasParameterBlock(pose)) continue;
    ceres_problem->SetManifold(pose, &manifold);
    if (held[k]) {
      ceres_problem->SetParameterBlockConstant(pose);
    } else {
      ++free_poses;
    }
  }
  return free_poses;
}

}  // namespace

BundleAdjustmentResult SolveBundleAdjustment(const BundleAdjustmentProblem& problem,
                                             const BundleAdjustmentOptions& options) {
  Parameters parameters = ParametersOf(problem);
  BundleAdjustmentResult result;
  result.outlier.assign(problem.observations.size(), false);
  for (int round = 0; round < 2; ++round) {
    ceres::Problem::Options problem_options;
    problem_options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    ceres::Problem ceres_problem(problem_options);
    if (AddObservations(problem, options, round, result.outlier, parameters, &ceres_problem) == 0) {
      break;
    }
    if (parameters.correction != nullptr) {
      const Eigen::Matrix<double, 5, 5> weight =
          Eigen::Matrix<double, 5, 5>::Identity() / problem.depth_correction_sigma;
      ceres_problem.AddResidualBlock(
          new ceres::NormalPrior(weight, Eigen::Matrix<double, 5, 1>::Zero()), nullptr,
          parameters.correction);
    }
    const std::vector<bool> held = HeldKeyframes(problem, options, result.outlier, &parameters);
    const int free_poses = SetUpPoses(held, &parameters, &ceres_problem);
    ceres::Solver::Options solver_options;
    solver_options.linear_solver_type =
        free_poses <= options.dense_schur_max_poses ? ceres::DENSE_SCHUR : ceres::SPARSE_SCHUR;
    solver_options.max_num_iterations =
        round == 0 ? options.iterations_first : options.iterations_second;
    solver_options.logging_type = ceres::SILENT;
    solver_options.num_threads = 1;
    ceres::Solver::Summary summary;
    ceres::Solve(solver_options, &ceres_problem, &summary);
    if (round == 0) result.initial_cost = summary.initial_cost;
    result.final_cost = summary.final_cost;
    result.iterations += static_cast<int>(summary.iterations.size());
    ClassifyObservations(problem, options, parameters, &result.outlier);
  }
  ReadResult(problem, parameters, &result);
  return result;
}

}  // namespace stillmap
