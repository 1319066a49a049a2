// The configuration of a `stillmap build` run: every option of every component under one dotted
// key ("mapping.voxel_leaf_size"), read from a YAML file and `--set key=value`, written back as the
// effective configuration next to the outputs.
#pragma once

#include <string>
#include <vector>

#include "stillmap/io/evaluation.h"
#include "stillmap/io/given_poses.h"
#include "stillmap/io/option_names.h"
#include "stillmap/io/sequence.h"
#include "stillmap/mapping/keyframe_selection.h"
#include "stillmap/mapping/map_mesh.h"
#include "stillmap/mapping/mapper.h"
#include "stillmap/mapping/occupancy_grid.h"
#include "stillmap/pipeline/dense_refinement_options.h"
#include "stillmap/pipeline/merge_options.h"
#include "stillmap/tracking/detector.h"
#include "stillmap/tracking/dynamic_mask.h"
#include "stillmap/tracking/tracker.h"
#include "stillmap/tracking/trajectory_smoothing.h"
#include "stillmap/viewer/renders.h"

namespace stillmap {

// What the command line decides about a run, kept with the other keys so that config.yaml repeats
// the run (`--config OUT/config.yaml`); --poses, --detector, --models and --threads override it.
struct RunSettings {
  std::string poses = "tracking";  // tracking | groundtruth | FILE | tf:FRAME | odom:TOPIC
  std::string detector = "auto";
  std::string models;  // "" = $STILLMAP_MODELS, else ../shared/models when present
  int threads = 2;

  // Every field under its configuration key (io/option_fields.h).
  template <typename Self, typename Visitor>
  static void VisitFields(Self& self, Visitor& visit) {
    visit("poses", self.poses,
          "tracking, groundtruth (the sequence's ground truth), a TUM trajectory file, tf:FRAME "
          "(a bag's /tf tree from FRAME to the camera) or odom:TOPIC (a bag's odometry); "
          "poses.use says how given poses are used (--poses)");
    visit("detector", self.detector,
          "auto, none, yolo-fastest, yolox, yolo-fastest+yolox, deeplab or both (--detector)");
    visit("models", self.models,
          "folder holding yolo_fastest_1.1/, yolox_nano/ and deeplabv3_mnv2_voc/ (--models)");
    visit("threads", self.threads, "threads, 1..64 (--threads)");
  }
};

// The frame of every 3-D output: map.ply, map.pcd, map.bt, map.ot, the mesh, trajectory.txt and
// keyframes.txt (grid.yaml places the grid in it).
struct MapFrameOptions {
  // floor: REP-103, z up from the floor plane at z = 0, the origin on the floor under the first
  // camera, x along its viewing direction projected on the floor; camera: the first camera's
  // optical frame (x right, y down, z forward); groundtruth: the ground truth's world frame.
  std::string frame = "floor";

  // Every field under its configuration key (io/option_fields.h).
  template <typename Self, typename Visitor>
  static void VisitFields(Self& self, Visitor& visit) {
    visit("frame", self.frame,
          "floor (z up, floor at z = 0, origin under the first camera, x along its view), camera "
          "(the first camera's optical frame), groundtruth (groundtruth.txt's world) or poses (the "
          "world of the poses given by --poses FILE|tf:FRAME|odom:TOPIC)");
  }
};

struct BuildConfig {
  RunSettings run;
  GivenPoseOptions poses;  // run.poses given as a file, tf:FRAME or odom:TOPIC
  MapFrameOptions map;
  CameraOverrides camera;
  SequenceOptions sequence;
  size_t first_frame = 0;  // index of the first color/depth pair to use
  size_t max_frames = 0;   // pairs to use from first_frame; 0 = all
  MapperOptions mapping;
  TrackerOptions tracking;
  bool masking_enabled = true;  // false: no dynamic rejection at all (the ablation baseline)
  DynamicMaskOptions masking;
  // Before a keyframe is fused, the depth check is run again against keyframes on both sides of
  // it in time, with final poses (catches people the online check could not see yet, e.g. in the
  // first keyframe).
  bool map_recheck = true;
  // With --poses groundtruth every frame is fused and every n-th one becomes a depth-check
  // reference (5: 6 per second at 30 Hz, enough for masking.reference_spacing_s).
  int groundtruth_reference_interval = 5;
  KeyframeSelectionOptions selection;
  GridOptions grid;
  MapMeshOptions mesh;
  RenderOptions render;
  FastestOptions fastest;
  YoloxOptions yolox;
  DeeplabOptions deeplab;
  std::string detector_levels;  // overrides of the motion-level table: "chair=low,book=high"
  AteOptions ate;
  RpeOptions rpe;
  MergeOptions merge;                  // stillmap merge
  DenseRefinementOptions final_poses;  // tracked builds: the keyframes' poses refined densely
  TrajectorySmoothingOptions trajectory_smoothing;  // tracked builds: the frames' poses
  // Write session.bin, what `stillmap merge` joins sessions from (tracked builds only).
  bool session_record = true;

  // Throws InputError naming the key of the first impossible value.
  void Validate() const;

  // The configuration keys: "section.key", each field of each component once
  // (io/option_fields.h).
  template <typename Self, typename Visitor>
  static void VisitFields(Self& self, Visitor& visit) {
    visit.Section("run", self.run);
    visit.Section("poses", self.poses);
    visit.Section("map", self.map);
    visit("map.session_record", self.session_record,
          "write session.bin: the fused keyframes' poses, features and compact images, for "
          "stillmap merge (tracked builds)");
    visit.Section("camera", self.camera);
    visit.Section("sequence", self.sequence);
    visit("sequence.first_frame", self.first_frame, "index of the first color/depth pair used");
    visit("sequence.max_frames", self.max_frames, "pairs used from first_frame; 0 = all");
    visit.Section("mapping", self.mapping);
    visit.Section("tracking", self.tracking);
    visit("masking.enabled", self.masking_enabled,
          "dynamic rejection (false: every pixel is used)");
    visit.Section("masking", self.masking);
    visit("masking.map_recheck", self.map_recheck,
          "re-run the depth check on each keyframe against its neighbours (both sides in time, "
          "final poses) before fusing it");
    visit("masking.groundtruth_reference_interval", self.groundtruth_reference_interval,
          "with --poses groundtruth, every n-th frame is a depth-check reference");
    visit.Section("keyframes", self.selection);
    visit.Section("grid", self.grid);
    visit.Section("mesh", self.mesh);
    visit.Section("render", self.render);
    visit.Section("detector", self.fastest);
    visit.Section("detector", self.yolox);
    visit.Section("detector", self.deeplab);
    visit("detector.levels", self.detector_levels,
          "motion-level overrides, e.g. chair=low,book=high (levels: high, medium, low)");
    visit.Section("eval", self.ate);
    visit.Section("eval", self.rpe, "rpe_");
    visit.Section("merge", self.merge);
    visit.Section("final_poses", self.final_poses);
    visit.Section("final_poses", self.trajectory_smoothing);
  }
};

// Records every key of the configuration in the option registry (io/option_names.h), once, so
// that the components' messages name their keys as the configuration has them. The build, the
// merge and the configuration's own functions call it; a program that reads components' messages
// before any of them (a command's help) calls it first.
void RegisterConfigKeys();

// One configurable key, for help texts.
struct ConfigKeyInfo {
  std::string name;
  std::string help;
  std::string default_value;  // as written in config.yaml; empty: unset (taken from the sequence)
};
std::vector<ConfigKeyInfo> ListConfigKeys();

// The motion-level table with config.detector_levels applied (InputError for a bad entry).
MotionLevelTable MotionLevels(const BuildConfig& config);

// Sets one key from its text value; throws InputError naming `where` (the file and line, or
// "--set") for an unknown key (listing the known ones) or a value of the wrong type.
void SetConfigValue(BuildConfig* config, const std::string& key, const std::string& value,
                    const std::string& where);

// Applies "key=value" as given to --set.
void ApplySetArgument(BuildConfig* config, const std::string& argument);

// Applies a YAML file of nested sections ("mapping:\n  voxel_leaf_size: 0.02") or dotted keys.
void ApplyConfigFile(BuildConfig* config, const std::string& path);

// The effective configuration as YAML, every key with its value; reading it back with
// ApplyConfigFile reproduces `config`.
std::string ConfigToYaml(const BuildConfig& config);

}  // namespace stillmap
