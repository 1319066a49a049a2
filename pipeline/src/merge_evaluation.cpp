#include "merge_evaluation.h"

#include <filesystem>

#include "stillmap/io/error.h"

namespace stillmap {
namespace {

namespace fs = std::filesystem;

// Each joined session's trajectory against its sequence's groundtruth.txt (when the sequence
// folder has one), on its own and all together under one rigid alignment.
void EvaluateSessions(const std::vector<MergeSession>& sessions, const JoinedSessions& joined,
                      const std::vector<Trajectory>& trajectories, const AteOptions& options,
                      MergeEvaluation* evaluation) {
  std::vector<Eigen::Vector3d> estimates, truths;
  for (size_t s = 0; s < sessions.size(); ++s) {
    if (!joined.included[s]) continue;
    const fs::path truth_path = fs::path(sessions[s].record().sequence) / "groundtruth.txt";
    if (!fs::is_regular_file(truth_path)) {
      evaluation->ate_notes[s] = "no " + truth_path.string();
      continue;
    }
    try {
      Trajectory truth = Trajectory::ReadTum(truth_path.string());
      const Camera& camera = sessions[s].record().camera;
      if (camera.groundtruth_body_from_camera) {
        truth = truth.RightMultiplied(*camera.groundtruth_body_from_camera);
      }
      const AteResult& ate = *(evaluation->ate[s] = ComputeAte(truth, trajectories[s], options));
      const Eigen::Isometry3d estimate_from_truth = ate.groundtruth_from_estimate.inverse();
      for (size_t i = 0; i < ate.aligned_positions.size(); ++i) {
        estimates.push_back(estimate_from_truth * ate.aligned_positions[i]);
        truths.push_back(ate.groundtruth_positions[i]);
      }
    } catch (const InputError& e) {
      evaluation->ate_notes[s] = e.what();
    }
  }
  if (estimates.size() < 3) return;
  Eigen::Matrix3Xd from(3, static_cast<Eigen::Index>(estimates.size()));
  Eigen::Matrix3Xd to(3, from.cols());
  for (size_t i = 0; i < estimates.size(); ++i) {
    from.col(static_cast<Eigen::Index>(i)) = estimates[i];
    to.col(static_cast<Eigen::Index>(i)) = truths[i];
  }
  const Eigen::Isometry3d align(Eigen::umeyama(from, to, false));
  std::vector<double> errors;
  for (size_t i = 0; i < estimates.size(); ++i) {
    errors.push_back((align * estimates[i] - truths[i]).norm());
  }
  evaluation->ate_joint = ComputeStatistics(std::move(errors));
}

// The merged map against the first session's static ground truth (synthetic sequences), in the
// truth's frame: placed by the fit of the first session's keyframes to their ground-truth poses
// (FitPoses, as a build's figures).
std::optional<MapQuality> EvaluateMergedMap(const std::vector<MergeSession>& sessions,
                                            const std::vector<VoxelPoint>& cloud) {
  const SessionRecord& first = sessions[0].record();
  const fs::path folder(first.sequence);
  if (!fs::is_regular_file(folder / "static_gt.ply") ||
      !fs::is_regular_file(folder / "groundtruth.txt")) {
    return std::nullopt;
  }
  Trajectory truth = Trajectory::ReadTum((folder / "groundtruth.txt").string());
  if (first.camera.groundtruth_body_from_camera) {
    truth = truth.RightMultiplied(*first.camera.groundtruth_body_from_camera);
  }
  std::vector<Eigen::Isometry3d> truths, estimates;
  for (const SessionKeyframe& keyframe : first.keyframes) {
    const std::optional<Eigen::Isometry3d> truth_pose = truth.Interpolate(keyframe.time, 0.1);
    if (!truth_pose) continue;
    truths.push_back(*truth_pose);
    estimates.push_back(keyframe.map_from_camera);
  }
  if (truths.empty()) return std::nullopt;
  const Eigen::Isometry3f truth_from_map = FitPoses(truths, estimates).cast<float>();
  return EvaluateMap(cloud, ReadCloud((folder / "static_gt.ply").string()), {}, truth_from_map);
}

}  // namespace

MergeEvaluation EvaluateMerge(const std::vector<MergeSession>& sessions,
                              const JoinedSessions& joined,
                              const std::vector<Trajectory>& trajectories,
                              const std::vector<VoxelPoint>& cloud, const AteOptions& options) {
  MergeEvaluation evaluation;
  evaluation.ate.resize(sessions.size());
  evaluation.ate_notes.resize(sessions.size());
  EvaluateSessions(sessions, joined, trajectories, options, &evaluation);
  evaluation.map_quality = EvaluateMergedMap(sessions, cloud);
  return evaluation;
}

}  // namespace stillmap
