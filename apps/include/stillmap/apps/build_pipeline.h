// `stillmap build`: a sequence in, every map output out. Library code, so that tests drive it
// exactly as the command line does.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "stillmap/apps/config.h"
#include "stillmap/mapping/map_quality.h"
#include "stillmap/mapping/occupancy_grid.h"

namespace stillmap {

// Where the camera poses come from.
enum class PoseSource {
  kGroundTruth,  // the sequence's groundtruth.txt, interpolated to each frame's time
  kTracking,     // the tracker of tracking/ (the default)
};

struct BuildRequest {
  std::string sequence_dir;
  std::string output_dir;
  BuildConfig config;
  PoseSource poses = PoseSource::kTracking;
  std::string detector = "none";  // none, yolox, deeplab or both
  std::string models_dir;         // holds yolox_nano/ and deeplabv3_mnv2_voc/
  int threads = 2;             // 1: decode and map in one thread; >= 2: decode the next frame ahead
  bool show_progress = false;  // a progress line on stderr
};

// What a run did; the same figures are written to report.json.
struct BuildSummary {
  size_t frames_paired = 0;        // color/depth pairs in the range used
  size_t frames_fused = 0;         // frames back-projected into the map
  size_t frames_tracked = 0;       // frames with a pose in trajectory.txt
  size_t frames_without_pose = 0;  // frames outside the ground truth (or across a gap in it)
  size_t map_points = 0;           // voxels in map.ply
  size_t octomap_leaves = 0;
  double wall_time_s = 0.0;
  double frames_per_second = 0.0;  // frames_paired / wall time
  double peak_memory_mib = 0.0;
  // Against the sequence's static_gt.ply, when it has one (synthetic sequences).
  std::optional<MapQuality> map_quality;
  std::optional<GridQuality> grid_quality;  // when grid.pgm was written and static_gt.ply exists
  // ATE RMSE [m] of the tracked trajectory, when the sequence has ground truth.
  std::optional<double> ate_rmse;
  size_t keyframes_invalid = 0;    // not fused: too much of the frame masked
  size_t keyframes_redundant = 0;  // not fused: landmarks already seen by the selected ones
  double dynamic_share = 0.0;      // mean masked share of the frames
  // Against the sequence's masks/ (synthetic sequences): pixel precision, recall, IoU.
  std::optional<double> mask_precision, mask_recall, mask_iou;
  // What the user should know about the result (also report.json "warnings"): parts of the map
  // that may be misaligned, points the maps could not hold, earlier outputs restored.
  std::vector<std::string> warnings;
};

// Runs the whole build. Throws InputError for bad input or options (before anything is written),
// std::runtime_error when the run fails (an empty map among others). The outputs are staged aside
// and swapped in whole only when all exist (io/output_files.h); the output folder is locked.
BuildSummary RunBuild(const BuildRequest& request);

}  // namespace stillmap
