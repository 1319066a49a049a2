#include "build_command.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <map>
#include <set>

#include "stillmap/io/error.h"
#include "stillmap/io/option_names.h"
#include "stillmap/io/output_files.h"
#include "stillmap/pipeline/build_pipeline.h"
#include "stillmap/pipeline/model_search.h"
#include "stillmap/pipeline/report.h"

namespace stillmap_app {

void BuildCommand::RecoverEarlierSwap() const {
  if (request.output_dir.empty()) return;
  const std::string recovered = stillmap::RecoverOutputFolder(request.output_dir, "build");
  if (!recovered.empty()) spdlog::warn("{}: {}", request.output_dir, recovered);
}

void BuildCommand::Add(CLI::App& app) {
  command = app.add_subcommand(
      "build",
      fmt::format(
          "Build the maps of a TUM-layout sequence: map.ply, map.pcd, map.bt, map.ot, grid.pgm + "
          "grid.yaml, mesh.glb, trajectory.txt, keyframes.txt, renders/, report.json, report.html, "
          "config.yaml, session.bin (for stillmap merge); the 3-D outputs in one z-up map frame "
          "({}).",
          stillmap::OptionKey(&stillmap::MapFrameOptions::frame)));
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
  config.Add(command, "YAML configuration file");
  AddRunOptions();
  CLI::Option* quiet_flag = command->add_flag("--quiet", quiet, "no progress line, warnings only");
  command
      ->add_flag("--verbose", verbose,
                 "also the libraries' own messages (PCL, OpenCV, Ceres), which are off by "
                 "default")
      ->excludes(quiet_flag);
  command->footer(ConfigKeysHelp());
}

void BuildCommand::AddRunOptions() {
  const std::string use = stillmap::OptionKey(&stillmap::GivenPoseOptions::use);
  command->add_option(
      "--poses", poses,
      fmt::format("where the camera poses come from: tracking (the default), groundtruth (the "
                  "sequence's ground truth), FILE.txt (a TUM trajectory, world_from_body, with "
                  "{}), tf:FRAME (a bag's /tf and /tf_static, from FRAME, e.g. odom or map, to "
                  "the colour image's frame_id) or odom:TOPIC (a bag's nav_msgs/Odometry, joined "
                  "to the camera through /tf_static). Given poses are used as they are ({}=map: "
                  "no visual tracking) or as the tracker's prior ({}=prior); {}=poses puts the "
                  "outputs in their world",
                  stillmap::OptionKey(&stillmap::GivenPoseOptions::body_from_camera), use, use,
                  stillmap::OptionKey(&stillmap::MapFrameOptions::frame)));
  command
      ->add_option("--detector", detector,
                   "semantic prior for dynamic rejection: auto (the default: "
                   "yolo-fastest+yolox when both models are found, else the one found, else "
                   "none), none (geometry only), yolo-fastest (boxes, the fastest), yolox "
                   "(boxes), yolo-fastest+yolox (yolo-fastest, with yolox as a second opinion "
                   "on a share of its runs: where people come near the lens, move at the border "
                   "unboxed or are lost), deeplab (per-pixel), both (yolox and deeplab)")
      ->check(CLI::IsMember(
          {"auto", "none", "yolo-fastest", "yolox", "yolo-fastest+yolox", "deeplab", "both"}));
  command->add_option("--models", models,
                      "folder holding yolo_fastest_1.1/, yolox_nano/ and deeplabv3_mnv2_voc/ "
                      "(default: the first "
                      "that holds one of $STILLMAP_MODELS, ~/.local/share/stillmap/models, "
                      "PREFIX/share/stillmap/models, BIN/models, ../shared/models; "
                      "scripts/fetch-models gets them)");
  command
      ->add_option("--threads", threads,
                   "threads (1: everything on one thread, slower; the outputs are the same bytes)")
      ->check(CLI::Range(1, 64));
}

// --topic KIND=NAME as the sequence's topic keys.
void BuildCommand::ApplyTopics() {
  stillmap::SequenceOptions& sequence = request.config.sequence;
  const std::map<std::string, std::string*> fields = {{"color", &sequence.color_topic},
                                                      {"depth", &sequence.depth_topic},
                                                      {"camera_info", &sequence.camera_info_topic}};
  std::set<std::string> kinds;
  for (const std::string& topic : topics) {
    const size_t equals = topic.find('=');
    const std::string kind = topic.substr(0, equals);
    if (equals == std::string::npos || fields.count(kind) == 0) {
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
    *fields.at(kind) = topic.substr(equals + 1);
  }
}

// run.* (from --config or --set) decides unless the option itself was given; then the models
// folder is searched for when none is named.
void BuildCommand::ApplyRunOptions() {
  stillmap::RunSettings& run = request.config.run;
  if (command->count("--poses") > 0) run.poses = poses;
  if (command->count("--detector") > 0) run.detector = detector;
  if (command->count("--models") > 0) run.models = models;
  if (command->count("--threads") > 0) run.threads = threads;
  request.models_found_by = stillmap::ResolveModels(
      &run, command->count("--models") > 0 ? std::string("--models")
                                           : stillmap::OptionKey(&stillmap::RunSettings::models));
}

void BuildCommand::Run() {
  // --config is read before anything in the output folder is touched (it may be
  // OUT/config.yaml).
  try {
    config.ApplyTo(&request.config);
    ApplyTopics();
    if (!groundtruth.empty()) request.config.sequence.groundtruth = groundtruth;
  } catch (...) {
    RecoverEarlierSwap();
    throw;
  }
  RecoverEarlierSwap();
  ApplyRunOptions();
  request.show_progress = StartRun(quiet);
  const stillmap::BuildResult result = stillmap::RunBuild(request);
  EndRun(stillmap::SummaryLines(result, request.output_dir), result.warnings);
}

}  // namespace stillmap_app
