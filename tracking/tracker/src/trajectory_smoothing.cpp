// Frame poses smoothed by local quadratic fits in time (trajectory_smoothing.h).
#include "stillmap/tracking/trajectory_smoothing.h"

#include <fmt/format.h>

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <optional>

#include "stillmap/io/error.h"
#include "stillmap/io/option_names.h"

namespace stillmap {
namespace {

// Each frame's run, counted from 0.
std::vector<size_t> Runs(const std::vector<StampedPose>& poses,
                         const std::vector<bool>& run_start) {
  std::vector<double> intervals;
  for (size_t i = 1; i < poses.size(); ++i) intervals.push_back(poses[i].time - poses[i - 1].time);
  double median = 0.0;
  if (!intervals.empty()) {
    std::nth_element(intervals.begin(), intervals.begin() + intervals.size() / 2, intervals.end());
    median = intervals[intervals.size() / 2];
  }
  std::vector<size_t> run(poses.size(), 0);
  for (size_t i = 1; i < poses.size(); ++i) {
    const bool gap = poses[i].time - poses[i - 1].time > 1.5 * median;
    const bool starts = i < run_start.size() && run_start[i];
    run[i] = run[i - 1] + (starts || gap ? 1 : 0);
  }
  return run;
}

// How many frames on each side of i lie within half_width_s of it, in its run (the same number
// on both sides, so that the window is centred on the frame).
size_t HalfWindow(const std::vector<StampedPose>& poses, const std::vector<size_t>& run, size_t i,
                  double half_width_s) {
  half_width_s += 1e-6;  // timestamps' rounding: 6 frames at 30 Hz are 0.2 s
  size_t before = 0, after = 0;
  while (before < i && run[i - before - 1] == run[i] &&
         poses[i].time - poses[i - before - 1].time <= half_width_s) {
    ++before;
  }
  while (i + after + 1 < poses.size() && run[i + after + 1] == run[i] &&
         poses[i + after + 1].time - poses[i].time <= half_width_s) {
    ++after;
  }
  return std::min(before, after);
}

// The value at offset 0 of the least-squares quadratic through (offsets[j], values[j]) (at least
// three samples).
Eigen::Vector3d FitAtZero(const std::vector<double>& offsets,
                          const std::vector<Eigen::Vector3d>& values, double scale) {
  Eigen::Matrix3d normal = Eigen::Matrix3d::Zero();
  Eigen::Matrix3d right = Eigen::Matrix3d::Zero();  // a row per power of the offset
  for (size_t j = 0; j < offsets.size(); ++j) {
    const double x = offsets[j] / scale;  // about 1: a well-conditioned system
    const Eigen::Vector3d powers(1.0, x, x * x);
    normal += powers * powers.transpose();
    right += powers * values[j].transpose();
  }
  return normal.ldlt().solve(right).row(0).transpose();
}

Eigen::Vector3d RotationVector(const Eigen::Matrix3d& rotation) {
  const Eigen::AngleAxisd turn(rotation);
  return turn.angle() * turn.axis();
}

Eigen::Matrix3d FromRotationVector(const Eigen::Vector3d& vector) {
  const double angle = vector.norm();
  if (angle < 1e-15) return Eigen::Matrix3d::Identity();
  return Eigen::AngleAxisd(angle, vector / angle).toRotationMatrix();
}

// Frame i's position and rotation fitted to the frames within their windows.
Eigen::Isometry3d Smoothed(const std::vector<StampedPose>& poses, const std::vector<size_t>& run,
                           size_t i, const TrajectorySmoothingOptions& options) {
  Eigen::Isometry3d smoothed = poses[i].world_from_camera;
  const auto fit = [&](double half_width_s, auto&& value_of) {
    // Two frames on either side at least: a line through three would bend a curve's frames in.
    const size_t half = HalfWindow(poses, run, i, half_width_s);
    if (half < 2) return std::optional<Eigen::Vector3d>();
    std::vector<double> offsets;
    std::vector<Eigen::Vector3d> values;
    for (size_t j = i - half; j <= i + half; ++j) {
      offsets.push_back(poses[j].time - poses[i].time);
      values.push_back(value_of(poses[j].world_from_camera));
    }
    return std::optional<Eigen::Vector3d>(FitAtZero(offsets, values, half_width_s));
  };
  if (const std::optional<Eigen::Vector3d> position = fit(
          options.position_s, [](const Eigen::Isometry3d& pose) { return pose.translation(); })) {
    smoothed.translation() = *position;
  }
  const Eigen::Matrix3d own = poses[i].world_from_camera.linear();
  if (const std::optional<Eigen::Vector3d> turn =
          fit(options.rotation_s, [&own](const Eigen::Isometry3d& pose) {
            return RotationVector(own.transpose() * pose.linear());
          })) {
    smoothed.linear() =
        Eigen::Quaterniond(own * FromRotationVector(*turn)).normalized().toRotationMatrix();
  }
  return smoothed;
}

}  // namespace

void TrajectorySmoothingOptions::Validate() const {
  for (const double* value : {&position_s, &rotation_s}) {
    if (!(*value >= 0.0 && *value <= 10.0)) {
      throw InputError(fmt::format("{} must be 0..10 s", OptionKey(*this, *value)));
    }
  }
}

TrajectorySmoothingFigures SmoothTrajectory(const TrajectorySmoothingOptions& options,
                                            const std::vector<bool>& run_start,
                                            std::vector<StampedPose>* poses) {
  TrajectorySmoothingFigures figures;
  if (poses->empty()) return figures;
  const std::vector<size_t> run = Runs(*poses, run_start);
  figures.runs = run.back() + 1;
  std::vector<StampedPose> smoothed = *poses;
  double squared = 0.0;
  for (size_t i = 0; i < poses->size(); ++i) {
    smoothed[i].world_from_camera = Smoothed(*poses, run, i, options);
    const double move =
        (smoothed[i].world_from_camera.translation() - (*poses)[i].world_from_camera.translation())
            .norm();
    if (smoothed[i].world_from_camera.matrix() != (*poses)[i].world_from_camera.matrix()) {
      ++figures.frames_moved;
    }
    squared += move * move;
    figures.largest_move_m = std::max(figures.largest_move_m, move);
  }
  figures.rms_move_m = std::sqrt(squared / static_cast<double>(poses->size()));
  *poses = std::move(smoothed);
  return figures;
}

}  // namespace stillmap
