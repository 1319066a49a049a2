// What a `stillmap build` run did, as one typed value: report.json, report.html and the terminal
// summary are all written from it (pipeline/report.h).
#pragma once

#include <map>
#include <optional>
#include <string>
#include <vector>

#include "stillmap/io/camera.h"
#include "stillmap/io/evaluation.h"
#include "stillmap/mapping/map_cleaning.h"
#include "stillmap/mapping/map_quality.h"
#include "stillmap/mapping/mapper.h"
#include "stillmap/mapping/occupancy_grid.h"
#include "stillmap/pipeline/dense_refinement_options.h"
#include "stillmap/tracking/map_segments.h"
#include "stillmap/tracking/mask_stage.h"
#include "stillmap/tracking/planar_motion.h"
#include "stillmap/tracking/tracker.h"
#include "stillmap/tracking/trajectory_smoothing.h"

namespace stillmap {

// Where the camera poses come from.
enum class PoseSource {
  kGroundTruth,  // the sequence's groundtruth.txt, interpolated to each frame's time
  kTracking,     // the tracker of tracking/ (the default)
  kGiven,  // given poses (a file, a bag's tf tree or odometry) used as they are (poses.use=map)
};

// Poses given from outside the build (--poses FILE|tf:FRAME|odom:TOPIC): where they came from,
// how they were used, and the frames they had no pose for.
struct GivenPoseFigures {
  std::string source;       // run.poses as given; empty: none given
  std::string use;          // poses.use: map or prior
  std::string description;  // the file, or the chain of frames and the topics it came from
  std::string world_frame;  // the poses' world
  // Frames in the range used without a given pose: before the poses' span, after it, or across
  // a gap wider than poses.max_gap_s; and how far the farthest lay outside the span [s].
  size_t before = 0, after = 0, in_gaps = 0;
  double before_s = 0.0, after_s = 0.0;
  bool given() const { return !source.empty(); }
  size_t without_pose() const { return before + after + in_gaps; }
};

struct FrameCounts {
  size_t color_images = 0;       // lines of rgb.txt
  size_t depth_images = 0;       // lines of depth.txt
  size_t pairs_in_sequence = 0;  // color/depth pairs
  size_t pairs_used = 0;         // pairs in the range used (sequence.first_frame, max_frames)
  size_t without_pose = 0;       // outside the ground truth (or across a gap in it)
  size_t tracked = 0;            // frames with a pose in trajectory.txt
  size_t fused = 0;              // frames back-projected into the map
  // The streams' plausibility (pipeline/src/stream_checks.h): depth quantiles of all readings
  // and colour frames equal to the one before.
  double depth_median_m = 0.0;
  double depth_95th_percentile_m = 0.0;
  size_t frozen_colour = 0;
};

// The camera's up on its mount from the floor the map's keyframes saw (floor_normal.h).
struct FloorUpFigures {
  size_t keyframes_read = 0;
  size_t keyframes_seeing_floor = 0;
  Eigen::Vector3d tracked_up_in_camera = Eigen::Vector3d::UnitZ();  // the poses' mean
  bool taken = false;       // enough keyframes saw the floor: the plane took their median up
  double change_deg = 0.0;  // between the tracked up and the floor's
  double spread_deg = 0.0;  // the floors' normals from their median (median angle)
};

// Per-frame tracking figures (tracked runs).
struct TrackingFigures {
  std::optional<DenseRefinementFigures> dense_refinement;  // final_poses.dense_enabled
  TrajectorySmoothingFigures smoothing;                    // final_poses.smoothing_s
  TrackerStatistics statistics;
  std::map<std::string, size_t> status_counts;  // TrackStatusName -> frames
  std::vector<double> lost_times;               // frames without a pose [s]
  // New maps lost again before any of their keyframes was kept for a map: their frames count as
  // lost (TakeLostAgain, pipeline/src/segment_keeper.h), not as segments.
  std::vector<SegmentSummary> lost_again;
  bool prior = false;  // given poses were the tracker's prior (poses.use=prior)
  // Frames posed with too little static depth (occluded, predicted by the motion model) or
  // carried by the prior where vision failed [s].
  std::vector<double> flagged_times;
  std::vector<double> static_depth_share;  // per frame (TrackResult::static_depth_share)
  std::vector<double> extract_ms, match_ms, pose_ms, keyframe_ms, total_ms;  // per frame
  double fuse_ms = 0.0;  // fusing final keyframes into the map, on the main thread
  // Loop corrections: fusing the map again at the final poses (0 when nothing moved), the fused
  // keyframes that had moved, and the compact copies kept for it.
  double refuse_ms = 0.0;
  size_t refused_keyframes_moved = 0;
  double refusion_store_mib = 0.0;
  bool bundle_adjustment_thread = false;
  // tracking.planar_motion: the plane of the tracked poses (nothing when off or refused), whether
  // the fit refused (too few turns to find the vertical), and whether the final poses were put on
  // the plane ("auto" leaves them when the tracked poses did not keep to it).
  std::optional<PlanarMotion> planar_motion;
  bool planar_motion_refused = false;
  bool planar_motion_applied = false;
  // tracking.planar_motion_floor_*: the camera's up from the floor its keyframes saw, where the
  // plane was applied (nothing when off).
  std::optional<FloorUpFigures> planar_floor;
};

// Keyframe selection and the map re-check (tracked runs; with known poses every frame is fused).
struct SelectionFigures {
  size_t invalid = 0;                 // not fused: too much of the frame masked
  size_t redundant = 0;               // not fused: landmarks already seen by the selected ones
  size_t seen_before = 0;             // not fused: an earlier visit saw its view (RevisitCells)
  size_t recheck_additions = 0;       // keyframes the map re-check added moving pixels to
  size_t revisit_cells_left_out = 0;  // depth cells (16 px) of revisits an earlier visit saw
};

struct MaskingFigures {
  bool enabled = false;
  std::string detector = "none";
  bool semantics = false;       // a detector ran
  std::string models_dir;       // where its weights came from
  std::string models_found_by;  // "--models", "$STILLMAP_MODELS", ... (model_search.h)
  // masking.* as the mask stage used them: the KLT window and the flow corners resolved by
  // whether a detector runs (MaskStage).
  DynamicMaskOptions options;
  MaskingStatistics statistics;
};

struct MapFigures {
  MapperStatistics statistics;
  MapCleaningResult cleaning;
  size_t voxels = 0;               // in the voxel table
  size_t voxels_written = 0;       // in map.ply
  size_t voxels_out_of_range = 0;  // points beyond the voxel grid's reach
  double voxel_table_mib = 0.0;
  size_t octomap_leaves = 0;
  size_t octomap_occupied_leaves = 0;
  size_t octomap_points_out_of_range = 0;
};

struct MeshFigures {
  std::string file;  // mesh.glb, mesh.obj or mesh.ply
  size_t voxels = 0, vertices = 0, triangles = 0;
};

// Against the sequence's ground truth, when it has some.
struct EvaluationFigures {
  std::optional<AteResult> ate;
  std::optional<RpeResult> rpe;
  std::string trajectory_note;  // why the trajectory was not evaluated (or is partly)
  std::string rpe_note;
  std::optional<MapQuality> map_quality;  // against static_gt.ply
  std::string map_quality_note;
  std::string static_groundtruth;  // its path
  double map_evaluation_s = 0.0;
  std::optional<GridQuality> grid_quality;
  bool moving_objects_known = false;  // objects.txt gave the moving objects' paths
};

// Wall-clock times of the stages [ms] (not repeatable from run to run).
struct StageTimings {
  double processing_ms = 0.0;   // reading, masking, tracking and fusing every frame
  double load_wait_ms = 0.0;    // waiting for decoded frames
  std::vector<double> flow_ms;  // flow-check image work per frame, ahead with the decoding
  double map_cleaning_ms = 0.0, grid_ms = 0.0, mesh_ms = 0.0, write_ms = 0.0;
  std::optional<double> renders_ms;
  // CPU time (user + system) [ms]: the whole process up to the written outputs, the main
  // thread's frame loop (masks, tracking, keyframes) and its finishing (the fusion's end, map
  // cleaning, grid, mesh, files), and the reading thread's decoding and flow.
  double process_cpu_ms = 0.0, frame_loop_cpu_ms = 0.0, finish_cpu_ms = 0.0, reader_cpu_ms = 0.0;
  std::vector<double> core_busy;  // each core's busy share over the same time, whoever used it
};

// The frame of the 3-D outputs (MapFrameOptions) and the floor it was found from.
struct MapFrameFigures {
  std::string name;         // floor | camera | groundtruth | poses
  std::string description;  // for the files' headers and the report
  // The outputs' frame in the frame the poses were computed in (the first tracked camera's, or
  // the ground truth's world with --poses groundtruth).
  Eigen::Isometry3d poses_from_map = Eigen::Isometry3d::Identity();
  FloorPlane floor;  // in the poses' frame
  // The floor frame (FloorFrame: z up from the floor, origin under the first camera) in the
  // outputs' frame: the identity for map.frame=floor, the grid's frame for all.
  Eigen::Isometry3d map_from_floor = Eigen::Isometry3d::Identity();
  bool floor_found = false;  // a fitted or given plane; false: the cameras' mean up (gravity)
};

// Where the memory went (report.json timing.memory): what each owner held at the sample taken at
// the highest resident memory, and each owner's largest over all samples (pipeline/src/
// memory_ledger.h).
struct MemoryOwner {
  std::string name;
  double mib = 0.0;
};
struct MemoryFigures {
  double peak_watched_mib = 0.0;     // the highest resident memory read every 50 ms
  std::string peak_watched_phase;    // the phase the build was in then
  std::string peak_when;             // the phase of the highest sample
  double peak_sample_mib = 0.0;      // resident memory at that sample
  std::vector<MemoryOwner> at_peak;  // the owners at that sample, largest first
  std::vector<MemoryOwner> largest;  // each owner's largest, largest first
  size_t samples = 0;
};

struct BuildResult {
  std::string sequence_dir;
  std::string command_line;  // BuildRequest::command_line
  std::string started_utc;   // ISO 8601, when the build started
  PoseSource poses = PoseSource::kTracking;
  GivenPoseFigures given_poses;  // --poses FILE|tf:FRAME|odom:TOPIC
  Camera camera;
  int threads = 1;
  FrameCounts frames;
  std::optional<TrackingFigures> tracking;  // tracked runs
  SelectionFigures selection;
  // Tracked builds: every map segment (a new one after each loss relocalization did not undo),
  // how it was joined, and whether it is in the map or was written apart under segments/<id>/.
  std::vector<SegmentSummary> segments;
  SegmentLinkFigures segment_links;
  MaskingFigures masking;
  MapFigures map;
  MapFrameFigures map_frame;
  std::optional<MeshFigures> mesh;    // when mesh.enabled
  std::optional<OccupancyGrid> grid;  // when written (grid.enabled and the OctoMap on)
  EvaluationFigures evaluation;
  std::optional<std::vector<std::string>> renders;  // files under renders/, when render.enabled
  StageTimings timings;
  // What the user should know about the result (parts of the map that may be misaligned, points
  // the maps could not hold, earlier outputs restored).
  std::vector<std::string> warnings;
  double wall_time_s = 0.0;        // up to the written outputs (evaluation and renders aside)
  double frames_per_second = 0.0;  // frames.pairs_used / wall_time_s
  double peak_memory_mib = 0.0;
  MemoryFigures memory;

  bool tracked() const { return poses == PoseSource::kTracking; }
  // ATE RMSE [m] of the tracked trajectory, when it was evaluated.
  std::optional<double> AteRmse() const {
    if (!evaluation.ate) return std::nullopt;
    return evaluation.ate->translation.rmse;
  }
};

// Every top-level name a build writes (folders end with '/'): a rerun replaces all of them, so
// that no file of an earlier run stays beside the new set.
const std::vector<std::string>& BuildOutputNames();

}  // namespace stillmap
