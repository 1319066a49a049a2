#include "segment_output.h"

#include <fmt/format.h>

#include <opencv2/imgcodecs.hpp>

#include "stillmap/mapping/mapper.h"

namespace stillmap {
namespace {

// The segment's keyframes fused into a map of its own.
FinishedMap MapOf(const SessionKeyframeList& keyframes, const SegmentOutputContext& context) {
  MapperOptions options = context.config.mapping;
  options.in_background = false;
  Mapper mapper(context.inputs.camera, options);
  for (size_t k = 0; k < keyframes.size(); ++k) {
    const SessionKeyframeBlocks blocks = keyframes.Load(k);
    MapperFrame input;
    input.time = blocks.keyframe.time;
    input.color = cv::imdecode(blocks.color_jpeg, cv::IMREAD_COLOR);
    cv::imdecode(blocks.depth_png, cv::IMREAD_UNCHANGED)
        .convertTo(input.depth_m, CV_32F, context.depth_unit_m);  // moving pixels are 0
    input.world_from_camera = blocks.keyframe.map_from_camera;
    mapper.Integrate(input);
  }
  return mapper.Finish();
}

// The segment's map files, in its own frame; returns why no map could be made of it, or "".
std::string WriteSegmentMap(const SessionKeyframeList& keyframes, const PosedFrames& posed,
                            const SegmentOutputContext& context, OutputSet& outputs,
                            MapFrameFigures* frame) {
  try {
    FinishedBuildMap finished = FinishMapInFrame(MapOf(keyframes, context), posed, context.inputs,
                                                 context.masking, context.finish);
    StageTimings timings;
    WriteMapFiles(finished.map, &finished.cloud, finished.frame, finished.grid, context.files,
                  outputs, &timings);
    *frame = finished.frame;
    return "";
  } catch (const std::runtime_error& e) {
    return e.what();  // too little to map: its poses and keyframes are still the user's
  }
}

// One segment as a build of its own in `dir`; returns why its map could not be made, or "".
std::string WriteSegment(ApartSegment segment, const SegmentOutputContext& context,
                         const std::string& dir) {
  OutputSet outputs(dir, "build", BuildOutputNames());
  PosedFrames posed;
  posed.trajectory = std::move(segment.trajectory);
  for (size_t k = 0; k < segment.keyframes.size(); ++k) {
    const SessionKeyframe& keyframe = segment.keyframes.keyframe(k);
    posed.fused_poses.push_back({keyframe.time, keyframe.map_from_camera});
  }
  posed.session_depth_unit_m = context.depth_unit_m;
  MapFrameFigures frame;
  std::string failure = WriteSegmentMap(segment.keyframes, posed, context, outputs, &frame);
  posed.session_keyframes = std::move(segment.keyframes);
  WriteBuildFiles(&posed, frame, context.inputs, context.config, context.sequence_dir,
                  PoseSource::kTracking, outputs);
  outputs.Commit();
  return failure;
}

}  // namespace

std::string ApartSegmentWarning(const SegmentSummary& summary, const std::string& failure,
                                const std::string& path) {
  std::string warning = fmt::format(
      "tracking was lost at {:.2f} s and not relocalized, and the {:.1f} s after it ({:.2f} - "
      "{:.2f} s, {} frames) could not be placed in the map: it is not in the map but written "
      "apart in {}/ in a frame of its own ('stillmap merge' can join it with this build's "
      "session.bin)",
      summary.first_time, summary.last_time - summary.first_time, summary.first_time,
      summary.last_time, summary.frames, path);
  if (!failure.empty()) warning += "; it holds no map, only its poses: " + failure;
  return warning;
}

std::string LostAgainWarning(const SegmentSummary& summary) {
  return fmt::format(
      "tracking began anew at {:.2f} s after a loss and was lost again at {:.2f} s ({} frames) "
      "before any of its {} keyframe(s) was kept for a map (each was judged invalid, too much of "
      "it masked as moving, or redundant): nothing of it can be mapped or placed, so its frames "
      "count as lost (report.json: tracking.new_maps_lost_again)",
      summary.first_time, summary.last_time, summary.frames, summary.keyframes);
}

std::vector<std::string> WriteApartSegments(std::vector<ApartSegment> apart,
                                            const SegmentOutputContext& context,
                                            OutputSet& outputs) {
  std::vector<std::string> warnings;
  for (ApartSegment& segment : apart) {
    const SegmentSummary summary = segment.summary;
    const std::string name = fmt::format("segments/{}", summary.id);
    const std::string failure =
        WriteSegment(std::move(segment), context, outputs.TemporaryPath(name));
    warnings.push_back(ApartSegmentWarning(summary, failure, outputs.FinalPath(name)));
  }
  return warnings;
}

}  // namespace stillmap
