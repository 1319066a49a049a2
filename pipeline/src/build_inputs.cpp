#include "build_inputs.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <filesystem>

#include "stillmap/io/error.h"
#include "stillmap/io/input_files.h"
#include "stillmap/io/option_names.h"

namespace stillmap {
namespace {

// Refuses ground-truth poses the maps cannot hold (a motion-capture world far from its origin):
// OctoMap's keys reach +-1.6 km at 5 cm, and beyond them every insertion would be dropped.
void CheckWithinMapExtent(const std::vector<StampedPose>& poses, const InputOptions& options,
                          const std::string& what) {
  double farthest = 0.0;
  for (const StampedPose& pose : poses) {
    farthest = std::max(farthest, pose.world_from_camera.translation().cwiseAbs().maxCoeff());
  }
  const double reach = farthest + options.max_depth_m;
  const double extent = options.map_extent_m;
  if (reach >= extent) {
    throw InputError(fmt::format(
        "{}: the camera lies up to {:.0f} m from the poses' origin along an axis, but the maps "
        "reach {:.0f} m ({} {} m, {} {} m); shift the poses nearer their origin or coarsen the "
        "maps",
        what, farthest, extent, OptionKey(&OccupancyMapOptions::resolution),
        options.octomap_resolution_m, OptionKey(&VoxelCloudOptions::leaf_size),
        options.voxel_leaf_m));
  }
}

// A frame without a given pose, counted by why.
void CountMiss(const LookupMiss& miss, GivenPoseFigures* figures) {
  if (miss.kind == LookupMiss::Kind::kBefore) {
    ++figures->before;
    figures->before_s = std::max(figures->before_s, miss.seconds);
  } else if (miss.kind == LookupMiss::Kind::kAfter) {
    ++figures->after;
    figures->after_s = std::max(figures->after_s, miss.seconds);
  } else {
    ++figures->in_gaps;
  }
}

// The pose of a frame at `time` from the ground truth or the given poses.
std::optional<Eigen::Isometry3d> KnownPose(const InputOptions& options, const BuildInputs& inputs,
                                           double time, GivenPoseFigures* figures) {
  if (!inputs.given) {
    return inputs.sequence.groundtruth()->Interpolate(time, options.sequence.max_groundtruth_gap);
  }
  LookupMiss miss;
  std::optional<Eigen::Isometry3d> pose = inputs.given->At(time, &miss);
  if (!pose) CountMiss(miss, figures);
  return pose;
}

// The frames of [begin, end) to process; with known poses only those the poses cover, with their
// poses; with given poses as a prior, every frame, with its given pose when it has one.
void PickFrames(const InputOptions& options, size_t begin, size_t end, BuildInputs* inputs,
                GivenPoseFigures* figures) {
  const bool tracking = options.poses == PoseSource::kTracking;
  for (size_t i = begin; i < end; ++i) {
    const double time = inputs->sequence.frames()[i].time;
    if (tracking) {
      inputs->frame_indices.push_back(i);
      if (inputs->given) inputs->prior_poses.push_back(KnownPose(options, *inputs, time, figures));
      continue;
    }
    const std::optional<Eigen::Isometry3d> world_from_camera =
        KnownPose(options, *inputs, time, figures);
    if (!world_from_camera) continue;
    inputs->frame_indices.push_back(i);
    inputs->known_poses.push_back({time, *world_from_camera});
  }
}

// Opens the poses run.poses gives (a file, tf:FRAME or odom:TOPIC); their figures and warnings.
void OpenGivenPoses(const InputOptions& options, OpenedInputs* opened) {
  const GivenPoses given =
      GivenPoses::Open(opened->inputs.sequence, *options.given, options.given_options);
  spdlog::info("poses: {}", given.description());
  for (const std::string& warning : given.warnings()) opened->warnings.push_back(warning);
  GivenPoseFigures& figures = opened->given;
  figures.source = options.given->text;
  figures.use = options.given_options.use;
  figures.description = given.description();
  figures.world_frame = given.world_frame();
  opened->inputs.given = std::make_shared<const GivenPoses>(given);
}

// No frame has a given pose: say where the frames and the poses lie in time.
InputError NoFrameWithinGivenPoses(const BuildInputs& inputs, const GivenPoseFigures& figures,
                                   size_t first, size_t end) {
  const auto [span_first, span_last] = inputs.given->span();
  return InputError(fmt::format(
      "--poses {}: no frame has a pose: the frames lie at {:.3f} .. {:.3f} s, the poses at "
      "{:.3f} .. {:.3f} s ({} frames before them, by up to {:.3f} s; {} after, by up to {:.3f} s; "
      "{} across gaps wider than {}); are the stamps on one clock?",
      figures.source, inputs.sequence.frames()[first].time, inputs.sequence.frames()[end - 1].time,
      span_first, span_last, figures.before, figures.before_s, figures.after, figures.after_s,
      figures.in_gaps, OptionKey(&GivenPoseOptions::max_gap_s)));
}

// A TUM-layout folder, or a recorded bag (its notes logged, its warnings in the report).
BuildInputs OpenSequence(const InputOptions& options, std::vector<std::string>* warnings) {
  const std::string& folder = options.sequence_dir;
  if (IsBag(folder)) {
    Sequence sequence = Sequence::OpenBag(folder, options.camera, options.sequence);
    for (const std::string& note : sequence.notes()) spdlog::info("{}", note);
    for (const std::string& warning : sequence.warnings()) warnings->push_back(warning);
    const Camera camera = sequence.camera();
    return {camera, std::move(sequence), {}, {}, {}, {}};
  }
  CheckSequenceFolder(folder);
  for (const std::string* topic : {&options.sequence.color_topic, &options.sequence.depth_topic,
                                   &options.sequence.camera_info_topic}) {
    if (!topic->empty()) {
      throw InputError(folder + ": a TUM-layout folder has no topics, but " + Quoted(*topic) +
                       " is named (--topic or sequence.*_topic); name topics only for a bag");
    }
  }
  const Camera camera = ResolveCamera(folder, options.camera);
  return {camera, Sequence::Open(folder, camera, options.sequence), {}, {}, {}, {}};
}

}  // namespace

OpenedInputs OpenInputs(const InputOptions& options) {
  OpenedInputs opened;
  BuildInputs& inputs = opened.inputs;
  inputs = OpenSequence(options, &opened.warnings);
  const bool tracking = options.poses == PoseSource::kTracking;
  const std::string& no_poses = inputs.sequence.groundtruth_note();
  if (options.given) OpenGivenPoses(options, &opened);
  if (options.poses == PoseSource::kGroundTruth && !inputs.sequence.groundtruth()) {
    throw InputError((no_poses.empty() ? options.sequence_dir + ": no groundtruth.txt" : no_poses) +
                     "; --poses groundtruth needs the sequence's ground truth");
  }
  if (!no_poses.empty() && options.map_frame != "groundtruth") {
    opened.warnings.push_back(no_poses + ": the map is built without ATE and RPE");
  }
  if (options.map_frame == "groundtruth" && !inputs.sequence.groundtruth()) {
    throw InputError(options.sequence_dir +
                     fmt::format(": no groundtruth.txt; {}=groundtruth needs the sequence's ground "
                                 "truth ({}=floor puts the map on the floor)",
                                 OptionKey(&MapFrameOptions::frame),
                                 OptionKey(&MapFrameOptions::frame)));
  }
  const size_t total_pairs = inputs.sequence.frames().size();
  if (options.first_frame >= total_pairs) {
    throw InputError(fmt::format("{}=", OptionKey(&BuildConfig::first_frame)) +
                     std::to_string(options.first_frame) + " but the sequence has " +
                     std::to_string(total_pairs) + " color/depth pairs");
  }
  const size_t end = options.max_frames == 0
                         ? total_pairs
                         : std::min(total_pairs, options.first_frame + options.max_frames);
  PickFrames(options, options.first_frame, end, &inputs, &opened.given);
  FrameCounts& frames = opened.frames;
  frames.color_images = inputs.sequence.color_count();
  frames.depth_images = inputs.sequence.depth_count();
  frames.pairs_in_sequence = total_pairs;
  frames.pairs_used = end - options.first_frame;
  frames.without_pose = frames.pairs_used - inputs.frame_indices.size();
  if (inputs.given && opened.given.without_pose() == frames.pairs_used) {
    throw NoFrameWithinGivenPoses(inputs, opened.given, options.first_frame, end);
  }
  if (inputs.frame_indices.empty()) {
    throw InputError(options.sequence_dir +
                     ": no frame lies within the ground truth's time range (compare the timestamps "
                     "of rgb.txt and groundtruth.txt)");
  }
  if (!tracking) {
    CheckWithinMapExtent(inputs.known_poses, options,
                         inputs.given ? "--poses " + opened.given.source : "groundtruth.txt");
  }
  if (inputs.given && opened.given.without_pose() > 0) {
    const GivenPoseFigures& given = opened.given;
    spdlog::warn(
        "{} of {} frames have no pose from {} ({} before the poses begin, {} after they end, {} "
        "across gaps wider than {} s){}",
        given.without_pose(), frames.pairs_used, given.source, given.before, given.after,
        given.in_gaps, options.given_options.max_gap_s,
        tracking ? ": the tracker predicts those from its own motion model" : " and are left out");
  } else if (frames.without_pose > 0) {
    spdlog::warn(
        "{} of {} frames lie outside the ground truth (or across a gap wider than {} s) "
        "and are left out",
        frames.without_pose, frames.pairs_used, options.sequence.max_groundtruth_gap);
  }
  return opened;
}

}  // namespace stillmap
