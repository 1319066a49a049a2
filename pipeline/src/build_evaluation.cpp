#include "build_evaluation.h"

#include <Eigen/SVD>
#include <chrono>
#include <filesystem>
#include <utility>

#include "map_frame.h"
#include "stillmap/io/error.h"
#include "stillmap/io/input_files.h"
#include "stillmap/io/timing.h"
#include "stillmap/io/truth_files.h"

namespace stillmap {
namespace {

void EvaluateTrajectory(const BuildInputs& inputs, const EvaluationOptions& options,
                        const PosedFrames& posed, EvaluationFigures* evaluation) {
  if (options.poses == PoseSource::kGroundTruth) {
    evaluation->trajectory_note = "not evaluated: the poses are the ground truth";
    return;
  }
  if (!inputs.sequence.groundtruth()) {
    evaluation->trajectory_note = "not evaluated: the sequence has no groundtruth.txt";
    return;
  }
  const Trajectory& groundtruth = *inputs.sequence.groundtruth();
  try {
    evaluation->ate = ComputeAte(groundtruth, posed.trajectory, options.ate);
  } catch (const InputError& e) {
    evaluation->trajectory_note = std::string("not evaluated: ") + e.what();
    return;
  }
  try {
    evaluation->rpe = ComputeRpe(groundtruth, posed.trajectory, options.rpe);
  } catch (const InputError& e) {
    evaluation->rpe_note = std::string("not evaluated: ") + e.what();
  }
}

// The grid against the truth's occupancy over the same band, in the map's frame, and the cells
// occupied only because a moving object (objects.txt) stood there.
void EvaluateGridAgainst(const std::vector<VoxelPoint>& truth,
                         const Eigen::Isometry3d& map_from_groundtruth,
                         const std::string& sequence_dir, const OccupancyGrid& grid,
                         EvaluationFigures* evaluation) {
  std::vector<Eigen::Vector3d> truth_in_map;
  truth_in_map.reserve(truth.size());
  for (const VoxelPoint& point : truth) {
    truth_in_map.push_back(map_from_groundtruth * point.position.cast<double>());
  }
  std::vector<Eigen::Vector3d> moving_in_map;
  const std::string objects = (std::filesystem::path(sequence_dir) / "objects.txt").string();
  if (PathExists(objects)) {
    for (const ObjectPose& object : ReadObjectPoses(objects)) {
      moving_in_map.push_back(map_from_groundtruth * object.world_from_object.translation());
    }
  }
  evaluation->grid_quality = EvaluateGrid(grid, truth_in_map, moving_in_map);
  evaluation->moving_objects_known = !moving_in_map.empty();
}

// The map's place in the truth's frame: the fit of every posed frame that has a ground-truth pose
// (FitPoses). One frame's pose alone would count its heading error, 10 cm at 16 m on a floor,
// against every far wall. Nothing when no posed frame has a ground-truth pose.
std::optional<Eigen::Isometry3d> GroundTruthFromMap(const BuildInputs& inputs,
                                                    const EvaluationOptions& options,
                                                    const PosedFrames& posed) {
  if (!inputs.sequence.groundtruth()) return std::nullopt;
  std::vector<Eigen::Isometry3d> truths, estimates;
  for (const StampedPose& pose : posed.trajectory.poses()) {
    const std::optional<Eigen::Isometry3d> truth =
        inputs.sequence.groundtruth()->Interpolate(pose.time, options.max_groundtruth_gap_s);
    if (!truth) continue;
    truths.push_back(*truth);
    estimates.push_back(pose.world_from_camera);
  }
  if (truths.empty()) return std::nullopt;
  return FitPoses(truths, estimates);
}

// The map against the static ground truth of synthetic sequences, in the truth's frame.
void EvaluateMapQuality(const BuildInputs& inputs, const EvaluationOptions& options,
                        const PosedFrames& posed, const std::vector<VoxelPoint>& cloud,
                        const std::optional<OccupancyGrid>& grid, EvaluationFigures* out) {
  EvaluationFigures& evaluation = *out;
  const std::string truth_path =
      (std::filesystem::path(options.sequence_dir) / "static_gt.ply").string();
  if (!PathExists(truth_path)) return;
  evaluation.static_groundtruth = truth_path;
  const std::optional<Eigen::Isometry3d> groundtruth_from_map =
      GroundTruthFromMap(inputs, options, posed);
  if (!groundtruth_from_map) {
    evaluation.map_quality_note =
        "not evaluated: no tracked frame has a ground-truth pose to anchor the map";
    return;
  }
  const auto start = std::chrono::steady_clock::now();
  std::vector<VoxelPoint> truth = ReadCloud(truth_path);
  const double read_s = SecondsSince(start);
  if (grid) {  // first: the map's evaluation frees the truth's points
    EvaluateGridAgainst(truth, groundtruth_from_map->inverse(), options.sequence_dir, *grid,
                        &evaluation);
  }
  const auto map_start = std::chrono::steady_clock::now();
  evaluation.map_quality =
      stillmap::EvaluateMap(cloud, std::move(truth), {}, groundtruth_from_map->cast<float>());
  evaluation.map_evaluation_s = read_s + SecondsSince(map_start);  // the grid's not counted
}

}  // namespace

EvaluationFigures EvaluateBuild(const BuildInputs& inputs, const EvaluationOptions& options,
                                const PosedFrames& posed, const std::vector<VoxelPoint>& cloud,
                                const std::optional<OccupancyGrid>& grid) {
  EvaluationFigures evaluation;
  EvaluateTrajectory(inputs, options, posed, &evaluation);
  EvaluateMapQuality(inputs, options, posed, cloud, grid, &evaluation);
  return evaluation;
}

}  // namespace stillmap
