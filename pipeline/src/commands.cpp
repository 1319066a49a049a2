#include "stillmap/pipeline/commands.h"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <optional>

#include "stillmap/io/camera.h"
#include "stillmap/io/cloud_files.h"
#include "stillmap/io/error.h"
#include "stillmap/io/image_io.h"
#include "stillmap/io/input_files.h"
#include "stillmap/io/sequence.h"
#include "stillmap/io/trajectory.h"
#include "stillmap/mapping/occupancy_grid.h"
#include "stillmap/viewer/renders.h"
#include "stillmap/viewer/trajectory_plot.h"

namespace stillmap {
namespace {

namespace fs = std::filesystem;

nlohmann::json StatisticsJson(const ErrorStatistics& s) {
  return {{"count", s.count}, {"rmse", s.rmse}, {"mean", s.mean}, {"median", s.median},
          {"std", s.std_dev}, {"min", s.min},   {"max", s.max}};
}

std::string StatisticsLine(const std::string& name, const ErrorStatistics& s, double scale,
                           const std::string& unit) {
  return fmt::format(
      "{:<18} rmse {:.4f}  mean {:.4f}  median {:.4f}  std {:.4f}  min {:.4f}  "
      "max {:.4f} {}  ({} pairs)\n",
      name, s.rmse * scale, s.mean * scale, s.median * scale, s.std_dev * scale, s.min * scale,
      s.max * scale, unit, s.count);
}

}  // namespace

std::string RunEval(const EvalRequest& request) {
  if (!(request.ate.max_time_difference > 0.0 && request.ate.max_time_difference <= 1.0)) {
    throw InputError("--max-diff must be in (0, 1] s");
  }
  if (!(request.rpe.delta > 0.0 && std::isfinite(request.rpe.delta))) {
    throw InputError("--delta must be a positive number of seconds");
  }
  Trajectory groundtruth = Trajectory::ReadTum(request.groundtruth_path);
  const Trajectory estimate = Trajectory::ReadTum(request.estimate_path);

  std::string camera_path = request.camera_path;
  if (camera_path.empty()) {
    const fs::path beside = fs::path(request.groundtruth_path).parent_path() / "camera.yaml";
    if (PathExists(beside.string())) camera_path = beside.string();
  }
  std::string conversion = "none";
  if (!camera_path.empty()) {
    const Camera camera = LoadCameraYaml(camera_path);
    if (camera.groundtruth_body_from_camera) {
      groundtruth = groundtruth.RightMultiplied(*camera.groundtruth_body_from_camera);
      conversion = "groundtruth_body_from_camera of " + camera_path;
    }
  }

  const AteResult ate = ComputeAte(groundtruth, estimate, request.ate);
  // A trajectory too short for the delta still has its ATE: RPE is then left out, with why.
  std::optional<RpeResult> rpe;
  std::string rpe_note;
  try {
    rpe = ComputeRpe(groundtruth, estimate, request.rpe);
  } catch (const InputError& e) {
    rpe_note = std::string("not evaluated: ") + e.what();
  }
  if (!request.plot_path.empty()) WriteTrajectoryPlot(request.plot_path, ate);

  if (request.json) {
    nlohmann::json json = {{"groundtruth", request.groundtruth_path},
                           {"estimate", request.estimate_path},
                           {"groundtruth_conversion", conversion},
                           {"ate_m", StatisticsJson(ate.translation)},
                           {"rpe_translation_m_per_delta",
                            rpe ? StatisticsJson(rpe->translation) : nlohmann::json(nullptr)},
                           {"rpe_rotation_deg_per_delta",
                            rpe ? StatisticsJson(rpe->rotation) : nlohmann::json(nullptr)},
                           {"rpe_delta_s", request.rpe.delta},
                           {"max_time_difference_s", request.ate.max_time_difference},
                           {"estimate_poses", estimate.size()},
                           {"groundtruth_poses", groundtruth.size()}};
    if (!rpe) json["rpe_note"] = rpe_note;
    return json.dump(2) + "\n";
  }
  std::string text;
  text += fmt::format("ground truth: {} ({} poses; body-to-camera conversion: {})\n",
                      request.groundtruth_path, groundtruth.size(), conversion);
  text +=
      fmt::format("estimate:     {} ({} poses, {} associated within {} s)\n", request.estimate_path,
                  estimate.size(), ate.translation.count, request.ate.max_time_difference);
  text += StatisticsLine("ATE", ate.translation, 1.0, "m");
  if (rpe) {
    text +=
        StatisticsLine(fmt::format("RPE trans/{}s", request.rpe.delta), rpe->translation, 1.0, "m");
    text +=
        StatisticsLine(fmt::format("RPE rot/{}s", request.rpe.delta), rpe->rotation, 1.0, "deg");
  } else {
    text += "RPE: " + rpe_note + "\n";
  }
  if (!request.plot_path.empty()) text += "plot: " + request.plot_path + "\n";
  return text;
}

std::string DescribeSequence(const std::string& sequence_dir, const std::string& camera_preset) {
  CameraOverrides overrides;
  overrides.preset = camera_preset;
  const bool bag = IsBag(sequence_dir);
  if (!bag) CheckSequenceFolder(sequence_dir);
  if (!bag && camera_preset.empty() &&
      !PathExists((fs::path(sequence_dir) / "camera.yaml").string())) {
    // ResolveCamera's advice names build's --set, which info does not take.
    throw InputError(sequence_dir + ": no camera.yaml; name the camera with --camera-preset " +
                     CameraPresetChoices());
  }
  std::string text;
  if (bag) {
    text = DescribeBagTopics(sequence_dir);
    if (text.find("\nwould refuse:") != std::string::npos) return text;
  }
  const Sequence sequence =
      bag ? Sequence::OpenBag(sequence_dir, overrides)
          : Sequence::Open(sequence_dir, ResolveCamera(sequence_dir, overrides));
  const Camera& camera = sequence.camera();
  const auto& frames = sequence.frames();
  const double duration = frames.back().time - frames.front().time;
  text += fmt::format("sequence:   {}\n", sequence_dir);
  text += fmt::format("images:     {} color, {} depth, {} pairs within {} s\n",
                      sequence.color_count(), sequence.depth_count(), frames.size(),
                      sequence.options().max_pair_time_difference);
  text += fmt::format("duration:   {:.2f} s ({:.1f} pairs/s)\n", duration,
                      duration > 0 ? static_cast<double>(frames.size() - 1) / duration : 0.0);
  text += fmt::format("camera:     {}x{} fx {} fy {} cx {} cy {} distortion [{}] depth_factor {}\n",
                      camera.width, camera.height, camera.fx, camera.fy, camera.cx, camera.cy,
                      fmt::join(camera.Coefficients(), ", "), camera.depth_factor);
  if (sequence.groundtruth()) {
    size_t covered = 0;
    for (const FrameEntry& frame : frames) {
      if (sequence.groundtruth()->Interpolate(frame.time, sequence.options().max_groundtruth_gap)) {
        ++covered;
      }
    }
    text += fmt::format(
        "groundtruth: {} poses, {:.2f} s; {} of {} pairs have a pose{}\n",
        sequence.groundtruth()->size(),
        sequence.groundtruth()->poses().back().time - sequence.groundtruth()->poses().front().time,
        covered, frames.size(),
        camera.groundtruth_body_from_camera ? " (body-to-camera applied)" : "");
  } else {
    text += "groundtruth: none\n";
  }
  return text;
}

}  // namespace stillmap
