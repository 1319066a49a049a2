// `stillmap eval` and `stillmap info`: library code behind the subcommands.
#pragma once

#include <string>
#include <vector>

#include "stillmap/io/evaluation.h"

namespace stillmap {

struct EvalRequest {
  std::string groundtruth_path;
  std::string estimate_path;
  AteOptions ate;
  RpeOptions rpe;
  bool json = false;      // machine-readable output
  std::string plot_path;  // PNG top view; empty: none
  // camera.yaml whose groundtruth_body_from_camera converts body poses to camera poses. Empty:
  // the camera.yaml beside the ground-truth file, when it exists.
  std::string camera_path;
};

// Computes ATE and RPE, writes the plot when asked, and returns the text (or JSON) to print.
// Throws InputError for unreadable or non-overlapping trajectories.
std::string RunEval(const EvalRequest& request);

// A description of a sequence: pairs, duration, camera, ground-truth coverage.
std::string DescribeSequence(const std::string& sequence_dir, const std::string& camera_preset);

}  // namespace stillmap
