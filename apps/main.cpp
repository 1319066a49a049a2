// The stillmap command: parses arguments and calls the library. Exit status: 0 success, 1 the run
// failed, 2 bad usage or bad input.
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <charconv>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <set>

#include "stillmap/io/error.h"
#include "stillmap/io/output_files.h"
#include "stillmap/pipeline/build_pipeline.h"
#include "stillmap/pipeline/commands.h"
#include "stillmap/pipeline/library_messages.h"
#include "stillmap/pipeline/merge_pipeline.h"
#include "stillmap/pipeline/model_search.h"
#include "stillmap/pipeline/progress.h"
#include "stillmap/pipeline/report.h"
#include "stillmap/synth/synthetic.h"
#include "stillmap/viewer/build_folder.h"
#include "stillmap/viewer/view_window.h"

namespace {

// CLI11 converts "-5" to an unsigned option by wrapping around and clamps what overflows: this
// validator lets through only whole numbers that fit in 64 bits unsigned.
const CLI::Validator kWholeNumber(
    [](std::string& text) -> std::string {
      std::uint64_t value = 0;
      const char* end = text.data() + text.size();
      const auto [stop, error] = std::from_chars(text.data(), end, value);
      if (text.empty() || error != std::errc() || stop != end) {
        return "'" + text + "' is not a whole number from 0 to 18446744073709551615";
      }
      return "";
    },
    "UINT");

std::string ConfigKeysHelp() {
  std::string text =
      "Configuration keys (--set key=value, or in --config FILE.yaml), with their defaults:\n";
  for (const stillmap::ConfigKeyInfo& key : stillmap::ListConfigKeys()) {
    const std::string value = key.default_value.empty() ? "(from the sequence)" : key.default_value;
    text += "  " + key.name + " = " + value + "\n      " + key.help + "\n";
  }
  return text;
}

// Each subcommand: its options (Add) and the library call they become (Run).
struct BuildCommand {
  // A build killed while swapping its outputs in is completed first, even when this one is then
  // refused for a bad option.
  void RecoverEarlierSwap() const {
    if (request.output_dir.empty()) return;
    const std::string recovered = stillmap::RecoverOutputFolder(request.output_dir, "build");
    if (!recovered.empty()) spdlog::warn("{}: {}", request.output_dir, recovered);
  }

  stillmap::BuildRequest request;
  std::string config_file;
  std::vector<std::string> set_arguments;
  std::string poses;
  std::vector<std::string> topics;
  std::string groundtruth;
  bool quiet = false;
  bool verbose = false;
  CLI::App* command = nullptr;

  void Add(CLI::App& app) {
    command = app.add_subcommand(
        "build",
        "Build the maps of a TUM-layout sequence: map.ply, map.pcd, map.bt, map.ot, grid.pgm + "
        "grid.yaml, mesh.glb, trajectory.txt, keyframes.txt, renders/, report.json, report.html, "
        "config.yaml, session.bin (for stillmap merge); the 3-D outputs in one z-up map frame "
        "(map.frame).");
    command
        ->add_option("SEQUENCE_DIR", request.sequence_dir,
                     "TUM-layout sequence folder, or a recorded bag: a ROS 1 .bag, an .mcap or "
                     ".db3 file, or a ROS 2 bag folder")
        ->required();
    command->add_option("--topic", topics,
                        "a bag's topic: color=NAME, depth=NAME or camera_info=NAME (repeatable; "
                        "default: chosen by type, encoding and name; see `stillmap info BAG`)");
    command->add_option("--groundtruth", groundtruth,
                        "ground-truth trajectory (TUM format) for ATE and RPE, e.g. for a bag");
    command
        ->add_option("-o,--output", request.output_dir,
                     "output folder (created if needed; not the sequence folder or inside it)")
        ->required();
    command->add_option("--config", config_file, "YAML configuration file");
    command->add_option("--set", set_arguments, "key=value; overrides --config (repeatable)");
    command
        ->add_option(
            "--poses", poses,
            "'groundtruth': map from the sequence's ground-truth poses instead of tracking "
            "('tracking', the default)")
        ->check(CLI::IsMember({"groundtruth", "tracking"}));
    command
        ->add_option("--detector", request.detector,
                     "semantic prior for dynamic rejection: auto (the default: yolo-fastest when "
                     "its model is found, else yolox when its model is, else none), none "
                     "(geometry only), yolo-fastest (boxes, the fastest), yolox (boxes), deeplab "
                     "(per-pixel), both (yolox and deeplab)")
        ->check(CLI::IsMember({"auto", "none", "yolo-fastest", "yolox", "deeplab", "both"}));
    command->add_option("--models", request.models_dir,
                        "folder holding yolo_fastest_1.1/, yolox_nano/ and deeplabv3_mnv2_voc/ "
                        "(default: the first "
                        "that holds one of $STILLMAP_MODELS, ~/.local/share/stillmap/models, "
                        "PREFIX/share/stillmap/models, BIN/models, ../shared/models; "
                        "scripts/fetch-models gets them)");
    command
        ->add_option(
            "--threads", request.threads,
            "threads (1: everything on one thread, slower; the outputs are the same bytes)")
        ->check(CLI::Range(1, 64));
    CLI::Option* quiet_flag =
        command->add_flag("--quiet", quiet, "no progress line, warnings only");
    command
        ->add_flag("--verbose", verbose,
                   "also the libraries' own messages (PCL, OpenCV, Ceres), which are off by "
                   "default")
        ->excludes(quiet_flag);
    command->footer(ConfigKeysHelp());
  }

  // --topic KIND=NAME as the sequence.*_topic keys.
  void ApplyTopics() {
    std::set<std::string> kinds;
    for (const std::string& topic : topics) {
      const size_t equals = topic.find('=');
      const std::string kind = topic.substr(0, equals);
      if (equals == std::string::npos ||
          (kind != "color" && kind != "depth" && kind != "camera_info")) {
        throw stillmap::InputError("--topic " + stillmap::Quoted(topic) +
                                   ": expected color=NAME, depth=NAME or camera_info=NAME");
      }
      if (equals + 1 == topic.size()) {
        throw stillmap::InputError("--topic " + stillmap::Quoted(topic) +
                                   ": no topic name after '='; give " + kind + "=NAME");
      }
      if (!kinds.insert(kind).second) {
        throw stillmap::InputError("--topic " + kind +
                                   "= given twice; give each of color, depth and camera_info "
                                   "once");
      }
      stillmap::ApplySetArgument(&request.config,
                                 "sequence." + kind + "_topic=" + topic.substr(equals + 1));
    }
  }

  void Run() {
    // --config is read before anything in the output folder is touched (it may be
    // OUT/config.yaml).
    try {
      if (!config_file.empty()) stillmap::ApplyConfigFile(&request.config, config_file);
      for (const std::string& argument : set_arguments) {
        stillmap::ApplySetArgument(&request.config, argument);
      }
      ApplyTopics();
      if (!groundtruth.empty()) request.config.sequence.groundtruth = groundtruth;
    } catch (...) {
      RecoverEarlierSwap();
      throw;
    }
    RecoverEarlierSwap();
    // run.* (from --config or --set) decides unless the option itself was given.
    stillmap::RunSettings& run = request.config.run;
    if (command->count("--poses") > 0) run.poses = poses;
    if (command->count("--detector") > 0) run.detector = request.detector;
    if (command->count("--models") > 0) run.models = request.models_dir;
    if (command->count("--threads") > 0) run.threads = request.threads;
    request.poses = run.poses == "groundtruth" ? stillmap::PoseSource::kGroundTruth
                                               : stillmap::PoseSource::kTracking;
    request.detector = run.detector;
    request.models_dir = run.models;
    request.threads = run.threads;
    if (!request.models_dir.empty()) {
      request.models_found_by = command->count("--models") > 0 ? "--models" : "run.models";
    } else if (request.detector != "none") {
      if (const auto found = stillmap::FindModels()) {
        request.models_dir = found->path;
        request.models_found_by = found->found_by;
      }
    }
    request.show_progress = !quiet && stillmap::StderrIsTerminal();
    if (quiet) spdlog::set_level(spdlog::level::warn);
    const stillmap::BuildResult result = stillmap::RunBuild(request);
    for (const std::string& line : stillmap::SummaryLines(result, request.output_dir)) {
      spdlog::info("{}", line);
    }
    for (const std::string& warning : result.warnings) spdlog::warn("{}", warning);
  }
};

struct MergeCommand {
  stillmap::MergeRequest request;
  std::string config_file;
  std::vector<std::string> set_arguments;
  bool quiet = false;
  CLI::App* command = nullptr;

  void Add(CLI::App& app) {
    command = app.add_subcommand(
        "merge",
        "Merge sessions of one place (the output folders of stillmap build) into one map in the "
        "first session's map frame: map.ply, map.pcd, map.bt, map.ot, grid.pgm + grid.yaml, the "
        "mesh, trajectory_<session>.txt per session, renders/, report.json, report.html, "
        "config.yaml. Sessions are joined where place recognition finds and geometry verifies "
        "places they share; a session that shares none is left out with a warning (exit 2 when "
        "none can be joined). Where the place changed, the later recording wins.");
    command
        ->add_option("SESSION_DIRS", request.session_dirs,
                     "two or more build output folders (each holds session.bin); the first "
                     "sets the map frame")
        ->required();
    command->add_option("-o,--output", request.output_dir, "output folder for the merged map")
        ->required();
    command->add_option("--config", config_file,
                        "YAML configuration (default: the first session's config.yaml)");
    command->add_option("--set", set_arguments, "key=value; overrides --config (repeatable)");
    command->add_option("--threads", request.threads, "threads")->check(CLI::Range(1, 64));
    command->add_flag("--quiet", quiet, "no progress line, warnings only");
    command->footer("The merge.* keys of `stillmap build --help` tune how sessions are joined.");
  }

  void Run() {
    const std::string config =
        config_file.empty()
            ? (std::filesystem::path(request.session_dirs.front()) / "config.yaml").string()
            : config_file;
    if (std::filesystem::exists(config) || !config_file.empty()) {
      stillmap::ApplyConfigFile(&request.config, config);
    }
    for (const std::string& argument : set_arguments) {
      stillmap::ApplySetArgument(&request.config, argument);
    }
    request.show_progress = !quiet && stillmap::StderrIsTerminal();
    if (quiet) spdlog::set_level(spdlog::level::warn);
    const stillmap::MergeResult result = stillmap::RunMerge(request);
    for (const std::string& line : stillmap::MergeSummaryLines(result, request.output_dir)) {
      spdlog::info("{}", line);
    }
    for (const std::string& warning : result.warnings) spdlog::warn("{}", warning);
  }
};

struct EvalCommand {
  stillmap::EvalRequest request;
  CLI::App* command = nullptr;

  void Add(CLI::App& app) {
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

  void Run() const { std::cout << stillmap::RunEval(request); }
};

struct SynthCommand {
  stillmap::SynthOptions options;
  std::string out_dir;
  bool no_noise = false;
  CLI::App* command = nullptr;

  void Add(CLI::App& app) {
    std::string scenarios;
    for (const std::string& name : stillmap::SynthScenarioNames()) scenarios += " " + name;
    command = app.add_subcommand(
        "synth",
        "Render a synthetic dynamic RGB-D sequence with exact ground truth: TUM layout plus "
        "masks/, static_gt.ply, objects.txt.");
    command->add_option("OUT_DIR", out_dir, "output folder (new, or an earlier synth output)")
        ->required();
    command->add_option("--scenario", options.scenario, "one of:" + scenarios)->required();
    command->add_option("--frames", options.frames, "frames at 30 Hz (default 300)")
        ->check(kWholeNumber);
    command->add_option("--seed", options.seed, "textures, colors and noise (default 1)")
        ->check(kWholeNumber);
    command->add_flag("--motion-blur", options.motion_blur, "blur color over a 16 ms exposure");
    command->add_flag("--no-noise", no_noise, "exact depth and color (no sensor model)");
    command->add_option("--threads", options.threads, "frames rendered in parallel (default 2)");
  }

  void Run() {
    options.depth_noise = options.color_noise = !no_noise;
    const stillmap::SynthSummary summary = stillmap::WriteSyntheticSequence(out_dir, options);
    for (const std::string& warning : summary.warnings) spdlog::warn("{}", warning);
    spdlog::info(
        "{} frames of '{}' in {:.1f} s; {} static ground-truth points; {:.1f} % of "
        "pixels dynamic; written to {}",
        summary.frames, options.scenario, summary.seconds, summary.static_gt_points,
        100.0 * summary.dynamic_pixel_share, out_dir);
  }
};

struct ViewCommand {
  std::string out_dir;
  bool png = false;
  std::string screenshot;
  CLI::App* command = nullptr;

  void Add(CLI::App& app) {
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

  void Run() const {
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
};

struct InfoCommand {
  std::string sequence_dir;
  std::string camera_preset;
  CLI::App* command = nullptr;

  void Add(CLI::App& app) {
    command =
        app.add_subcommand("info",
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

  void Run() const {
    std::cout << stillmap::DescribeSequence(sequence_dir, camera_preset);
    std::cout << "detector:   " << stillmap::DescribeDefaultDetector() << "\n";
  }
};

int Run(int argc, char** argv) {
  spdlog::set_default_logger(spdlog::stderr_color_st("stillmap"));
  spdlog::set_pattern("stillmap: %l: %v");

  CLI::App app{"stillmap: clean static maps from RGB-D sequences in which people move."};
  app.set_version_flag("--version", std::string("stillmap ") + STILLMAP_VERSION);
  app.require_subcommand(1);
  BuildCommand build;
  for (int i = 0; i < argc; ++i) {
    build.request.command_line += (i > 0 ? " " : "") + std::string(argv[i]);
  }
  MergeCommand merge;
  merge.request.command_line = build.request.command_line;
  EvalCommand eval;
  SynthCommand synth;
  ViewCommand view;
  InfoCommand info;
  build.Add(app);
  merge.Add(app);
  eval.Add(app);
  synth.Add(app);
  view.Add(app);
  info.Add(app);

  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    // One sentence of ours, like every other refusal, naming the option CLI11 found wrong.
    if (*build.command) build.RecoverEarlierSwap();
    std::fprintf(stderr, "stillmap: error: %s (--help lists the options)\n", e.what());
    return 2;
  }

  stillmap::SetLibraryMessages(build.verbose);
  try {
    if (*build.command) build.Run();
    if (*merge.command) merge.Run();
    if (*eval.command) eval.Run();
    if (*synth.command) synth.Run();
    if (*view.command) view.Run();
    if (*info.command) info.Run();
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
