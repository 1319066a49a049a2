// The first step of a build: the inputs opened and checked before anything is written.
#pragma once

#include <memory>
#include <optional>
#include <vector>

#include "stillmap/io/camera.h"
#include "stillmap/io/given_poses.h"
#include "stillmap/io/sequence.h"
#include "stillmap/io/trajectory.h"
#include "stillmap/pipeline/build_result.h"
#include "stillmap/pipeline/config.h"

namespace stillmap {

struct BuildInputs {
  Camera camera;
  Sequence sequence;
  std::vector<size_t> frame_indices;  // the frames to process, in order
  // With --poses groundtruth or given poses used as they are: the pose of each frame of
  // frame_indices (frames without one are left out of frame_indices and never decoded).
  std::vector<StampedPose> known_poses;
  // Poses given as a file, tf:FRAME or odom:TOPIC (null otherwise).
  std::shared_ptr<const GivenPoses> given;
  // With given poses as the tracker's prior: each frame's given pose, when it has one.
  std::vector<std::optional<Eigen::Isometry3d>> prior_poses;
};

// What opening the inputs reads of the request.
struct InputOptions {
  std::string sequence_dir;  // a TUM-layout folder or a bag
  PoseSource poses = PoseSource::kTracking;
  std::optional<GivenPoseSource> given;  // run.poses naming a file, tf:FRAME or odom:TOPIC
  GivenPoseOptions given_options;        // poses.*
  std::string map_frame;                 // map.frame: "groundtruth" needs the ground truth
  CameraOverrides camera;
  SequenceOptions sequence;
  size_t first_frame = 0, max_frames = 0;  // sequence.first_frame, sequence.max_frames
  // The maps' reach, which ground-truth poses must lie within.
  double max_depth_m = 0.0, map_extent_m = 0.0, octomap_resolution_m = 0.0, voxel_leaf_m = 0.0;
};

struct OpenedInputs {
  BuildInputs inputs;
  FrameCounts frames;                 // the input counts (color_images .. without_pose)
  GivenPoseFigures given;             // with given poses
  std::vector<std::string> warnings;  // the bag's, then a missing ground truth's
};

// Opens the sequence, picks its frames and counts them. Throws InputError for a missing folder,
// bad lists or camera, a frame range beyond the sequence, ground-truth poses missing or beyond
// the maps' reach.
OpenedInputs OpenInputs(const InputOptions& options);

}  // namespace stillmap
