// The stillmap command: parses arguments and calls the library. Exit status: 0 success, 1 the run
// failed, 2 bad usage or bad input.
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <iostream>

#include "stillmap/io/error.h"
#include "stillmap/pipeline/build_pipeline.h"
#include "stillmap/pipeline/commands.h"
#include "stillmap/pipeline/progress.h"
#include "stillmap/pipeline/report.h"
#include "stillmap/synth/synthetic.h"
#include "stillmap/viewer/build_folder.h"
#include "stillmap/viewer/view_window.h"

namespace {

std::string ConfigKeysHelp() {
  std::string text = "Configuration keys (--set key=value, or in --config FILE.yaml):\n";
  for (const stillmap::ConfigKeyInfo& key : stillmap::ListConfigKeys()) {
    text += "  " + key.name + std::string(key.name.size() < 36 ? 36 - key.name.size() : 1, ' ') +
            key.help + "\n";
  }
  return text;
}

int Run(int argc, char** argv) {
  spdlog::set_default_logger(spdlog::stderr_color_st("stillmap"));
  spdlog::set_pattern("stillmap: %l: %v");

  CLI::App app{"stillmap: clean static maps from RGB-D sequences in which people move."};
  app.set_version_flag("--version", std::string("stillmap ") + STILLMAP_VERSION);
  app.require_subcommand(1);

  // build
  stillmap::BuildRequest build;
  std::string config_file;
  std::vector<std::string> set_arguments;
  std::string poses;
  bool quiet = false;
  CLI::App* build_cmd = app.add_subcommand(
      "build",
      "Build the maps of a TUM-layout sequence (map.ply, map.pcd, map.bt, map.ot, "
      "trajectory.txt, keyframes.txt, report.json, config.yaml).");
  build_cmd->add_option("SEQUENCE_DIR", build.sequence_dir, "TUM-layout sequence folder")
      ->required();
  build_cmd->add_option("-o,--output", build.output_dir, "output folder (created if needed)")
      ->required();
  build_cmd->add_option("--config", config_file, "YAML configuration file");
  build_cmd->add_option("--set", set_arguments, "key=value; overrides --config (repeatable)");
  build_cmd
      ->add_option("--poses", poses,
                   "'groundtruth': map from the sequence's ground-truth poses instead of tracking")
      ->check(CLI::IsMember({"groundtruth"}));
  build_cmd
      ->add_option("--detector", build.detector,
                   "semantic prior for dynamic rejection: none (geometry only, the default), "
                   "yolox (boxes), deeplab (per-pixel), both")
      ->check(CLI::IsMember({"none", "yolox", "deeplab", "both"}));
  build_cmd->add_option("--models", build.models_dir,
                        "folder holding yolox_nano/ and deeplabv3_mnv2_voc/ (default: "
                        "$STILLMAP_MODELS, else ../shared/models when present)");
  build_cmd
      ->add_option("--threads", build.threads,
                   "threads (1: no read-ahead, bundle adjustment inline, OpenCV single-threaded)")
      ->check(CLI::Range(1, 64));
  build_cmd->add_flag("--quiet", quiet, "no progress line, warnings only");
  build_cmd->footer(ConfigKeysHelp());

  // eval
  stillmap::EvalRequest eval;
  CLI::App* eval_cmd = app.add_subcommand(
      "eval",
      "ATE and RPE of a trajectory against ground truth, as the TUM benchmark computes "
      "them (association, Horn alignment without scale; RPE over a fixed time delta).");
  eval_cmd->add_option("GROUNDTRUTH", eval.groundtruth_path, "TUM-format ground truth")->required();
  eval_cmd->add_option("ESTIMATE", eval.estimate_path, "TUM-format estimate")->required();
  eval_cmd->add_flag("--json", eval.json, "print JSON instead of text");
  eval_cmd->add_option("--plot", eval.plot_path, "write a top-view PNG of both trajectories");
  eval_cmd->add_option("--max-diff", eval.ate.max_time_difference,
                       "association window [s] (default 0.02)");
  eval_cmd->add_option("--delta", eval.rpe.delta, "RPE time delta [s] (default 1.0)");
  eval_cmd->add_option("--camera", eval.camera_path,
                       "camera.yaml with groundtruth_body_from_camera (default: the one beside "
                       "GROUNDTRUTH, if any)");

  // synth
  stillmap::SynthOptions synth;
  std::string synth_dir;
  bool no_noise = false;
  std::string scenarios;
  for (const std::string& name : stillmap::SynthScenarioNames()) scenarios += " " + name;
  CLI::App* synth_cmd = app.add_subcommand(
      "synth",
      "Render a synthetic dynamic RGB-D sequence with exact ground truth: TUM layout plus "
      "masks/, static_gt.ply, objects.txt.");
  synth_cmd->add_option("OUT_DIR", synth_dir, "output folder (new, or an earlier synth output)")
      ->required();
  synth_cmd->add_option("--scenario", synth.scenario, "one of:" + scenarios)->required();
  synth_cmd->add_option("--frames", synth.frames, "frames at 30 Hz (default 300)");
  synth_cmd->add_option("--seed", synth.seed, "textures, colors and noise (default 1)");
  synth_cmd->add_flag("--motion-blur", synth.motion_blur, "blur color over a 16 ms exposure");
  synth_cmd->add_flag("--no-noise", no_noise, "exact depth and color (no sensor model)");
  synth_cmd->add_option("--threads", synth.threads, "frames rendered in parallel (default 2)");

  // view
  std::string view_dir;
  bool view_png = false;
  std::string view_screenshot;
  CLI::App* view_cmd = app.add_subcommand(
      "view",
      "Look at a build: a window with the cloud, the OctoMap's occupied voxels, the trajectory "
      "and the keyframes; --png draws the renders (renders/*.png) again instead.");
  view_cmd->add_option("OUT_DIR", view_dir, "a folder 'stillmap build' wrote")->required();
  view_cmd->add_flag("--png", view_png, "write renders/*.png (no display needed)");
  view_cmd->add_option("--screenshot", view_screenshot,
                       "render the window once into this PNG and close it");
  view_cmd->footer(std::string("Keys: ") + stillmap::kViewWindowKeys);

  // info
  std::string info_dir;
  std::string info_preset;
  CLI::App* info_cmd =
      app.add_subcommand("info", "Describe a sequence: pairs, duration, camera, ground truth.");
  info_cmd->add_option("SEQUENCE_DIR", info_dir, "TUM-layout sequence folder")->required();
  info_cmd->add_option("--camera-preset", info_preset,
                       "tum1|tum2|tum3|bonn|ros_default when the folder has no camera.yaml");

  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    app.exit(e);
    return 2;
  }

  try {
    if (*build_cmd) {
      if (!config_file.empty()) stillmap::ApplyConfigFile(&build.config, config_file);
      for (const std::string& argument : set_arguments) {
        stillmap::ApplySetArgument(&build.config, argument);
      }
      build.poses = poses == "groundtruth" ? stillmap::PoseSource::kGroundTruth
                                           : stillmap::PoseSource::kTracking;
      std::error_code models_error;
      if (build.models_dir.empty() && build.detector != "none") {
        const char* from_environment = std::getenv("STILLMAP_MODELS");
        if (from_environment != nullptr && *from_environment != '\0') {
          build.models_dir = from_environment;
        } else if (std::filesystem::is_directory("../shared/models", models_error)) {
          build.models_dir = "../shared/models";
        }
      }
      build.show_progress = !quiet && stillmap::StderrIsTerminal();
      if (quiet) spdlog::set_level(spdlog::level::warn);
      const stillmap::BuildResult result = stillmap::RunBuild(build);
      for (const std::string& line : stillmap::SummaryLines(result, build.output_dir)) {
        spdlog::info("{}", line);
      }
      for (const std::string& warning : result.warnings) spdlog::warn("{}", warning);
    } else if (*eval_cmd) {
      std::cout << stillmap::RunEval(eval);
    } else if (*synth_cmd) {
      synth.depth_noise = synth.color_noise = !no_noise;
      const stillmap::SynthSummary summary = stillmap::WriteSyntheticSequence(synth_dir, synth);
      spdlog::info(
          "{} frames of '{}' in {:.1f} s; {} static ground-truth points; {:.1f} % of "
          "pixels dynamic; written to {}",
          summary.frames, synth.scenario, summary.seconds, summary.static_gt_points,
          100.0 * summary.dynamic_pixel_share, synth_dir);
    } else if (*view_cmd) {
      if (view_png) {
        for (const std::string& path : stillmap::RenderBuildFolder(view_dir)) {
          spdlog::info("wrote {}", path);
        }
      } else {
        stillmap::RunViewWindow(view_dir, view_screenshot);
        if (!view_screenshot.empty()) spdlog::info("wrote {}", view_screenshot);
      }
    } else if (*info_cmd) {
      std::cout << stillmap::DescribeSequence(info_dir, info_preset);
    }
  } catch (const stillmap::InputError& e) {
    std::fprintf(stderr, "stillmap: error: %s\n", e.what());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "stillmap: failed: %s\n", e.what());
    return 1;
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return Run(argc, argv);
  } catch (const std::exception& e) {  // e.g. logging set-up; everything else is handled in Run
    std::fprintf(stderr, "stillmap: failed: %s\n", e.what());
    return 1;
  }
}
