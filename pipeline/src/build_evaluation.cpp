#include "build_evaluation.h"

#include <chrono>
#include <filesystem>

#include "map_frame.h"
#include "stillmap/io/error.h"
#include "stillmap/io/input_files.h"
#include "stillmap/io/timing.h"
#include "stillmap/io/truth_files.h"

namespace stillmap {
namespace {

void EvaluateTrajectory(const BuildInputs& inputs, const BuildRequest& request,
                        const PosedFrames& posed, EvaluationFigures* evaluation) {
  if (request.poses == PoseSource::kGroundTruth) {
    evaluation->trajectory_note = "not evaluated: the poses are the ground truth";
    return;
  }
  if (!inputs.sequence.groundtruth()) {
    evaluation->trajectory_note = "not evaluated: the sequence has no groundtruth.txt";
    return;
  }
  const Trajectory& groundtruth = *inputs.sequence.groundtruth();
  try {
    evaluation->ate = ComputeAte(groundtruth, posed.trajectory, request.config.ate);
  } catch (const InputError& e) {
    evaluation->trajectory_note = std::string("not evaluated: ") + e.what();
    return;
  }
  try {
    evaluation->rpe = ComputeRpe(groundtruth, posed.trajectory, request.config.rpe);
  } catch (const InputError& e) {
    evaluation->rpe_note = std::string("not evaluated: ") + e.what();
  }
}

// The grid against the truth's occupancy over the same band, in the map's frame, and the cells
// occupied only because a moving object (objects.txt) stood there.
void EvaluateGridAgainst(const std::vector<VoxelPoint>& truth,
                         const Eigen::Isometry3d& map_from_groundtruth,
                         const std::string& sequence_dir, BuildResult* result) {
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
  result->evaluation.grid_quality = EvaluateGrid(*result->grid, truth_in_map, moving_in_map);
  result->evaluation.moving_objects_known = !moving_in_map.empty();
}

// The map against the static ground truth of synthetic sequences, in the truth's frame.
void EvaluateMapQuality(const BuildInputs& inputs, const BuildRequest& request,
                        const PosedFrames& posed, const std::vector<VoxelPoint>& cloud,
                        BuildResult* result) {
  EvaluationFigures& evaluation = result->evaluation;
  const std::string truth_path =
      (std::filesystem::path(request.sequence_dir) / "static_gt.ply").string();
  if (!PathExists(truth_path)) return;
  evaluation.static_groundtruth = truth_path;
  const std::optional<Eigen::Isometry3d> groundtruth_from_map =
      GroundTruthFromPoses(inputs, request, posed);
  if (!groundtruth_from_map) {
    evaluation.map_quality_note =
        "not evaluated: no tracked frame has a ground-truth pose to anchor the map";
    return;
  }
  const auto start = std::chrono::steady_clock::now();
  std::vector<VoxelPoint> points = cloud;
  const Eigen::Isometry3f transform = groundtruth_from_map->cast<float>();
  for (VoxelPoint& point : points) point.position = transform * point.position;
  const std::vector<VoxelPoint> truth = ReadCloud(truth_path);
  evaluation.map_quality = stillmap::EvaluateMap(points, truth);
  evaluation.map_evaluation_s = SecondsSince(start);
  if (result->grid) {
    EvaluateGridAgainst(truth, groundtruth_from_map->inverse(), request.sequence_dir, result);
  }
}

}  // namespace

void EvaluateBuild(const BuildInputs& inputs, const BuildRequest& request, const PosedFrames& posed,
                   const std::vector<VoxelPoint>& cloud, BuildResult* result) {
  EvaluateTrajectory(inputs, request, posed, &result->evaluation);
  EvaluateMapQuality(inputs, request, posed, cloud, result);
}

}  // namespace stillmap
