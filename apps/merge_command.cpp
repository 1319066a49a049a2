#include "merge_command.h"

#include <filesystem>

#include "stillmap/pipeline/merge_report.h"

namespace stillmap_app {

void MergeCommand::Add(CLI::App& app) {
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
  config.Add(command, "YAML configuration (default: the first session's config.yaml)");
  command->add_option("--threads", threads, "threads")->check(CLI::Range(1, 64));
  command->add_flag("--quiet", quiet, "no progress line, warnings only");
  command->footer("The merge.* keys of `stillmap build --help` tune how sessions are joined.");
}

void MergeCommand::Run() {
  config.ApplyTo(&request.config,
                 (std::filesystem::path(request.session_dirs.front()) / "config.yaml").string());
  if (command->count("--threads") > 0) request.config.run.threads = threads;
  request.show_progress = StartRun(quiet);
  const stillmap::MergeResult result = stillmap::RunMerge(request);
  EndRun(stillmap::MergeSummaryLines(result, request.output_dir), result.warnings);
}

}  // namespace stillmap_app
