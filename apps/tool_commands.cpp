#include "tool_commands.h"

#include <spdlog/spdlog.h>

#include <iostream>

#include "command_steps.h"
#include "stillmap/io/output_files.h"
#include "stillmap/pipeline/model_search.h"
#include "stillmap/viewer/build_folder.h"
#include "stillmap/viewer/view_window.h"

namespace stillmap_app {

void EvalCommand::Add(CLI::App& app) {
  command = app.add_subcommand(
      "eval",
      "ATE and RPE of a trajectory against ground truth, as the TUM benchmark computes "
      "them (association, Horn alignment without scale; RPE over a fixed time delta).");
  command->add_option("GROUNDTRUTH", request.groundtruth_path, "TUM-format ground truth")
      ->required();
  command->add_option("ESTIMATE", request.estimate_path, "TUM-format estimate")->required();
  command->add_flag("--json", request.json, "print JSON instead of text");
  command->add_option("--plot", request.plot_path, "write a top-view PNG of both trajectories");
  command->add_option("--max-diff", request.ate.max_time_difference,
                      "association window [s] (default 0.02)");
  command->add_option("--delta", request.rpe.delta, "RPE time delta [s] (default 1.0)");
  command->add_option("--camera", request.camera_path,
                      "camera.yaml with groundtruth_body_from_camera (default: the one beside "
                      "GROUNDTRUTH, if any)");
}

void EvalCommand::Run() const { std::cout << stillmap::RunEval(request); }

void SynthCommand::Add(CLI::App& app) {
  std::string scenarios;
  for (const std::string& name : stillmap::SynthScenarioNames()) scenarios += " " + name;
  command = app.add_subcommand(
      "synth",
      "Render a synthetic dynamic RGB-D sequence with exact ground truth: TUM layout plus "
      "masks/, static_gt.ply, objects.txt.");
  command->add_option("OUT_DIR", out_dir, "output folder (new, or an earlier synth output)")
      ->required();
  command->add_option("--scenario", options.scenario, "one of:" + scenarios)->required();
  command
      ->add_option("--frames", options.frames,
                   "frames at 30 Hz (default: 300; floor and floor_lost: their whole path)")
      ->check(kWholeNumber);
  command->add_option("--seed", options.seed, "textures, colors and noise (default 1)")
      ->check(kWholeNumber);
  command->add_flag("--motion-blur", options.motion_blur, "blur color over a 16 ms exposure");
  command->add_flag("--no-noise", no_noise, "exact depth and color (no sensor model)");
  command->add_option("--threads", options.threads, "frames rendered in parallel (default 2)");
}

void SynthCommand::Run() {
  options.depth_noise = options.color_noise = !no_noise;
  const stillmap::SynthSummary summary = stillmap::WriteSyntheticSequence(out_dir, options);
  for (const std::string& warning : summary.warnings) spdlog::warn("{}", warning);
  spdlog::info(
      "{} frames of '{}' in {:.1f} s; {} static ground-truth points; {:.1f} % of "
      "pixels dynamic; written to {}",
      summary.frames, options.scenario, summary.seconds, summary.static_gt_points,
      100.0 * summary.dynamic_pixel_share, out_dir);
}

void ViewCommand::Add(CLI::App& app) {
  command = app.add_subcommand(
      "view",
      "Look at a build: a window with the cloud, the OctoMap's occupied voxels, the trajectory "
      "and the keyframes; --png draws the renders (renders/*.png) again instead.");
  command->add_option("OUT_DIR", out_dir, "a folder 'stillmap build' wrote")->required();
  command->add_flag("--png", png, "write renders/*.png (no display needed)");
  command->add_option("--screenshot", screenshot,
                      "render the window once into this PNG and close it");
  command->footer(std::string("Keys: ") + stillmap::kViewWindowKeys);
}

void ViewCommand::Run() const {
  // A build killed while swapping its outputs in is completed before anything is read.
  const std::string recovered = stillmap::RecoverOutputFolder(out_dir, "build");
  if (!recovered.empty()) spdlog::warn("{}: {}", out_dir, recovered);
  if (png) {
    for (const std::string& path : stillmap::RenderBuildFolder(out_dir)) {
      spdlog::info("wrote {}", path);
    }
  } else {
    stillmap::RunViewWindow(out_dir, screenshot);
    if (!screenshot.empty()) spdlog::info("wrote {}", screenshot);
  }
}

void InfoCommand::Add(CLI::App& app) {
  command = app.add_subcommand("info",
                               "Describe a sequence: pairs, duration, camera, ground truth; for a "
                               "bag, its topics and the ones a build would use.");
  command
      ->add_option("SEQUENCE_DIR", sequence_dir,
                   "TUM-layout sequence folder, or a recorded bag: a ROS 1 .bag, an .mcap or "
                   ".db3 file, or a ROS 2 bag folder")
      ->required();
  command->add_option("--camera-preset", camera_preset,
                      stillmap::CameraPresetChoices() + " when the folder has no camera.yaml");
}

void InfoCommand::Run() const {
  std::cout << stillmap::DescribeSequence(sequence_dir, camera_preset);
  std::cout << "detector:   " << stillmap::DescribeDefaultDetector() << "\n";
}

}  // namespace stillmap_app
