// Sequence::OpenBag: a recorded bag as a sequence (issue 28).
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>

#include "bag/bag_frames.h"
#include "stillmap/io/error.h"
#include "stillmap/io/option_names.h"
#include "stillmap/io/sequence.h"

namespace stillmap {
namespace {

bool SameCamera(const RosCameraInfo& a, const RosCameraInfo& b) {
  if (a.width != b.width || a.height != b.height) return false;
  for (size_t i = 0; i < a.k.size(); ++i) {
    if (std::abs(a.k[i] - b.k[i]) > 1e-3 * std::max(1.0, std::abs(a.k[i]))) return false;
  }
  return true;
}

// The camera of a CameraInfo message: K, and plumb_bob (k1 k2 p1 p2 k3) or rational_polynomial
// (k1 k2 p1 p2 k3 k4 k5 k6) distortion.
Camera CameraFromInfo(const RosCameraInfo& info, const std::string& where) {
  Camera camera;
  camera.width = static_cast<int>(info.width);
  camera.height = static_cast<int>(info.height);
  camera.fx = info.k[0];
  camera.cx = info.k[2];
  camera.fy = info.k[4];
  camera.cy = info.k[5];
  const bool plumb_bob = info.distortion_model == "plumb_bob" || info.d.empty();
  const bool rational = info.distortion_model == "rational_polynomial";
  bool fits = plumb_bob ? info.d.size() <= 5 : rational;
  for (size_t i = 8; rational && i < info.d.size(); ++i) fits = fits && info.d[i] == 0.0;
  if (!fits) {
    throw InputError(fmt::format(
        "{}: distortion model {} with {} coefficients is not read (plumb_bob k1 k2 p1 p2 k3, "
        "rational_polynomial k1 k2 p1 p2 k3 k4 k5 k6, librealsense's Brown Conrady forms); give "
        "the camera with --set {}=... {}=... {}=... {}=... {}=...",
        where, Quoted(info.distortion_model), info.d.size(), OptionKey(&CameraOverrides::fx),
        OptionKey(&CameraOverrides::fy), OptionKey(&CameraOverrides::cx),
        OptionKey(&CameraOverrides::cy), OptionKey(&CameraOverrides::distortion)));
  }
  for (size_t i = 0; i < std::min<size_t>(5, info.d.size()); ++i) camera.distortion[i] = info.d[i];
  for (size_t i = 5; i < std::min<size_t>(8, info.d.size()); ++i)
    camera.rational[i - 5] = info.d[i];
  camera.depth_factor = 1000.0;  // REP 118: 16-bit depth in millimetres
  return camera;
}

// The camera overrides applied, each named in a note.
Camera WithOverrides(Camera camera, const CameraOverrides& overrides,
                     std::vector<std::string>* notes) {
  std::string given;
  auto take = [&](const auto& value, auto& field, const std::string& key) {
    if (!value) return;
    field = *value;
    given += std::string(given.empty() ? "" : ", ") + key;
  };
  take(overrides.width, camera.width, OptionKey(&CameraOverrides::width));
  take(overrides.height, camera.height, OptionKey(&CameraOverrides::height));
  take(overrides.fx, camera.fx, OptionKey(&CameraOverrides::fx));
  take(overrides.fy, camera.fy, OptionKey(&CameraOverrides::fy));
  take(overrides.cx, camera.cx, OptionKey(&CameraOverrides::cx));
  take(overrides.cy, camera.cy, OptionKey(&CameraOverrides::cy));
  take(overrides.distortion, camera.distortion, OptionKey(&CameraOverrides::distortion));
  if (overrides.distortion) camera.rational = {};  // the given k1..k3 model replaces the bag's
  take(overrides.depth_factor, camera.depth_factor, OptionKey(&CameraOverrides::depth_factor));
  if (!given.empty()) notes->push_back(given + " given: used instead of the bag's CameraInfo");
  return camera;
}

bool IsIdentity(const Eigen::Isometry3d& pose) {
  return pose.isApprox(Eigen::Isometry3d::Identity(), 1e-9);
}

// A RealSense recorder bag's depth registered into colour with the recording's own extrinsics;
// none is needed when depth shares colour's camera and place.
std::unique_ptr<DepthRegistration> RealSenseRegistration(
    const BagContents& contents, const std::string& color, const std::string& depth,
    const BagStream& info, const BagStream* own, const std::string& path,
    std::vector<std::string>* notes) {
  const std::optional<Eigen::Isometry3d> color_from_depth = RealSenseColorFromDepth(
      contents.realsense, RealSenseStreamOf(color), RealSenseStreamOf(depth));
  const bool same_camera = own == nullptr || SameCamera(own->info, info.info);
  if (same_camera && (!color_from_depth || IsIdentity(*color_from_depth))) return nullptr;
  if (own == nullptr || !color_from_depth) {
    throw InputError(path + ": depth " + depth + " is not registered to colour " + color +
                     (own == nullptr ? " and has no camera info (" + CameraInfoTopicOf(depth) + ")"
                                     : " and the recording holds no extrinsic linking them (" +
                                           RealSenseStreamOf(depth) + "/tf/<group>)") +
                     "; record with the RealSense Viewer's \"Align depth to color\" or name a "
                     "registered depth topic with --topic depth=NAME");
  }
  notes->push_back("depth " + depth + " registered into colour with the recording's extrinsics (" +
                   RealSenseStreamOf(depth) + "/tf, " + RealSenseStreamOf(color) + "/tf)");
  return std::make_unique<DepthRegistration>(own->info, info.info, *color_from_depth,
                                             path + ": " + own->name);
}

// Depth with a camera of its own (its CameraInfo differs from colour's) is registered into colour
// through /tf_static (a RealSense recorder bag: through its extrinsics); none is needed when it
// shares colour's camera.
std::unique_ptr<DepthRegistration> RegistrationOf(const BagContents& contents,
                                                  const BagStream& color, const BagStream& depth,
                                                  const BagStream& info, const std::string& path,
                                                  std::vector<std::string>* notes) {
  const std::string depth_info = CameraInfoTopicOf(depth.name);
  const BagStream* own = nullptr;
  for (const BagStream& stream : contents.streams) {
    if (stream.name == depth_info && stream.has_info) own = &stream;
  }
  if (!RealSenseStreamOf(depth.name).empty() && !RealSenseStreamOf(color.name).empty()) {
    return RealSenseRegistration(contents, color.name, depth.name, info, own, path, notes);
  }
  if (own == nullptr || SameCamera(own->info, info.info)) return nullptr;
  const std::string& depth_frame = own->info.header.frame_id;
  const std::string& color_frame = info.info.header.frame_id;
  const std::optional<Eigen::Isometry3d> color_from_depth =
      FindStaticTransform(contents.static_transforms, color_frame, depth_frame);
  if (!color_from_depth) {
    throw InputError(path + ": depth topic " + depth.name + " has a camera of its own (" +
                     depth_info + " differs from " + info.name + ") and no /tf_static transform " +
                     "links its frame " + Quoted(depth_frame) + " to colour's " +
                     Quoted(color_frame) +
                     ". Record the registered depth (realsense2_camera: aligned_depth_to_color; "
                     "openni: depth_registered; Azure Kinect: depth_to_rgb) and name it with "
                     "--topic depth=NAME, or record /tf_static too");
  }
  notes->push_back("depth " + depth.name + " registered into colour with /tf_static (" +
                   depth_frame + " in " + color_frame + ")");
  return std::make_unique<DepthRegistration>(own->info, info.info, *color_from_depth,
                                             path + ": " + depth_info);
}

// A RealSense recorder bag's depth scale: its depth sensor's Depth Units option [m per unit];
// none for other bags.
std::optional<double> RealSenseDepthUnits(const BagContents& contents, const BagStream& depth,
                                          const std::string& path) {
  const std::string sensor = RealSenseSensorOf(RealSenseStreamOf(depth.name));
  const auto units = contents.realsense.depth_units.find(sensor);
  if (sensor.empty() || units == contents.realsense.depth_units.end()) return std::nullopt;
  if (!(units->second > 0.0 && units->second < 1.0)) {
    throw InputError(fmt::format(
        "{}: {}/option/Depth Units/value says {} m per depth unit, which no depth camera "
        "records; give the scale with --set {}=UNITS_PER_METRE",
        path, sensor, std::to_string(units->second), OptionKey(&CameraOverrides::depth_factor)));
  }
  return units->second;
}

}  // namespace

bool IsBag(const std::string& path) { return LooksLikeBag(path); }

std::string DescribeBagTopics(const std::string& path, const SequenceOptions& options) {
  std::unique_ptr<BagReader> reader = stillmap::OpenBag(path);
  const BagContents contents = ScanBagContents(*reader);
  std::string text;
  const std::string device = DescribeRealSenseDevice(contents.realsense);
  if (!device.empty()) text += "device: " + device + " (RealSense recorder layout)\n";
  text += "topics:\n" + DescribeBagStreams(contents);
  for (const std::string& warning : contents.warnings) text += "warning: " + warning + "\n";
  try {
    const BagChoice choice = ChooseBagStreams(
        contents, {options.color_topic, options.depth_topic, options.camera_info_topic}, false,
        path);
    text += "would use: colour " + contents.streams[choice.color].name + ", depth " +
            contents.streams[choice.depth].name + ", camera " +
            contents.streams[choice.camera_info].name + "\n";
  } catch (const InputError& error) {
    const std::string what = error.what();
    text += "would refuse: " + what.substr(0, what.find(';')) + "\n";
  }
  return text;
}

namespace {

// The smallest time between a colour and a depth header stamp [s] (both lists in any order).
double NearestGap(std::vector<double> color, std::vector<double> depth) {
  std::sort(color.begin(), color.end());
  std::sort(depth.begin(), depth.end());
  double gap = std::numeric_limits<double>::infinity();
  size_t d = 0;
  for (const double c : color) {
    while (d + 1 < depth.size() && depth[d + 1] <= c) ++d;
    for (size_t k = d; k < std::min(d + 2, depth.size()); ++k) {
      gap = std::min(gap, std::abs(depth[k] - c));
    }
  }
  return gap;
}

// The InputError `error` with what the bag's reading met (damage skipped, messages left out)
// after it: that is often why a stream is missing.
InputError WithWarnings(const InputError& error, const std::vector<std::string>& warnings) {
  std::string text = error.what();
  if (warnings.empty()) return InputError(text);
  text += "\nReading the bag met:";
  for (const std::string& warning : warnings) text += "\n  " + warning;
  return InputError(text);
}

bool CameraGiven(const CameraOverrides& overrides) {
  return !overrides.preset.empty() ||
         (overrides.fx && overrides.fy && overrides.cx && overrides.cy);
}

// The camera: the CameraInfo's (info may be null when the camera is given), else the preset's,
// then the keys given; a 16-bit depth image is in millimetres (REP 118) unless
// camera.depth_factor says otherwise.
Camera CameraOfBag(const BagStream* info, const CameraOverrides& overrides, const std::string& path,
                   std::vector<std::string>* notes) {
  Camera camera;
  if (!overrides.preset.empty()) {
    camera = CameraPreset(overrides.preset);
    camera.depth_factor = 1000.0;
    notes->push_back(
        fmt::format("{}=", OptionKey(&CameraOverrides::preset)) + overrides.preset +
        " given: used " +
        (info == nullptr ? "(the bag has no CameraInfo)" : "instead of the bag's CameraInfo"));
  } else if (info != nullptr) {
    camera = CameraFromInfo(info->info, path + ": " + info->name);
  } else {
    camera.depth_factor = 1000.0;
  }
  return WithOverrides(camera, overrides, notes);
}

}  // namespace

Sequence Sequence::OpenBag(const std::string& path, const CameraOverrides& overrides,
                           const SequenceOptions& options) {
  if (!(options.max_pair_time_difference > 0.0)) {
    throw InputError(
        fmt::format("{} must be positive", OptionKey(options, options.max_pair_time_difference)));
  }
  std::unique_ptr<BagReader> reader = stillmap::OpenBag(path);
  BagContents contents = ScanBagContents(*reader);
  BagChoice choice;
  try {
    choice = ChooseBagStreams(contents,
                              {options.color_topic, options.depth_topic, options.camera_info_topic},
                              CameraGiven(overrides), path);
  } catch (const InputError& error) {
    throw WithWarnings(error, contents.warnings);
  }
  const BagStream& color = contents.streams[choice.color];
  const BagStream& depth = contents.streams[choice.depth];
  for (const BagStream* stream : {&color, &depth}) {
    if (stream->count == 1 && stream->repeated > 0) {
      throw WithWarnings(InputError(path + ": every message on " + stream->name +
                                    " has the same header stamp; colour and depth are paired "
                                    "and the trajectory timed by the stamps (record with the "
                                    "driver's stamps set)"),
                         contents.warnings);
    }
  }
  const BagStream* info =
      choice.camera_info == BagChoice::kNone ? nullptr : &contents.streams[choice.camera_info];
  std::vector<std::string> notes;
  std::unique_ptr<DepthRegistration> registration =
      info == nullptr ? nullptr : RegistrationOf(contents, color, depth, *info, path, &notes);
  Sequence sequence;
  sequence.dir_ = path;
  sequence.options_ = options;
  sequence.warnings_ = contents.warnings;
  sequence.notes_ = contents.notes;
  sequence.notes_.insert(sequence.notes_.end(), notes.begin(), notes.end());
  sequence.notes_.push_back("topics: colour " + color.name + ", depth " + depth.name + ", camera " +
                            (info == nullptr ? "given, no CameraInfo" : info->name));
  Camera camera = CameraOfBag(info, overrides, path, &sequence.notes_);
  const std::optional<double> units = RealSenseDepthUnits(contents, depth, path);
  if (units && !overrides.depth_factor) {
    camera.depth_factor = 1.0 / *units;
    sequence.notes_.push_back("depth units " + std::to_string(*units) + " m from " +
                              RealSenseSensorOf(RealSenseStreamOf(depth.name)) +
                              "/option/Depth Units");
  }
  if (info == nullptr && overrides.preset.empty() && !overrides.width && color.width > 0) {
    camera.width = color.width, camera.height = color.height;  // a raw colour topic's own size
  }
  auto frames =
      std::make_shared<BagFrames>(std::move(reader), color, depth, 1.0 / camera.depth_factor);
  if (registration != nullptr) frames->RegisterDepth(std::move(registration));
  frames->Pair(color, depth, options.max_pair_time_difference, &sequence.frames_);
  if (sequence.frames_.empty()) {
    char gap[64], window[32];
    std::snprintf(gap, sizeof(gap), "%.3f s", NearestGap(color.stamps, depth.stamps));
    std::snprintf(window, sizeof(window), "%g s", options.max_pair_time_difference);
    throw WithWarnings(
        InputError(fmt::format(
            "{}: no colour message on {} has a depth message on {} within {} of its header "
            "stamp; the nearest are {} apart (stamps on different clocks? widen the window with "
            "--set {}=SECONDS)",
            path, color.name, depth.name, window, gap,
            OptionKey(&SequenceOptions::max_pair_time_difference))),
        contents.warnings);
  }
  if (info == nullptr && overrides.preset.empty() && !overrides.width && color.width == 0) {
    cv::Mat first_color, first_depth;  // a compressed colour topic: its size is its first image's
    frames->Load(0, sequence.frames_[0].time, &first_color, &first_depth);
    camera.width = first_color.cols, camera.height = first_color.rows;
  }
  camera.Validate(path + ": " + (info == nullptr ? std::string("the camera given") : info->name));
  sequence.camera_ = camera;
  sequence.color_count_ = color.count;
  sequence.depth_count_ = depth.count;
  sequence.bag_ = std::move(frames);
  auto poses = std::make_shared<RecordedPoses>(std::move(contents.poses));
  poses->color_frame = color.frame_id;
  sequence.recorded_poses_ = std::move(poses);
  if (!options.groundtruth.empty()) sequence.ReadGroundtruth(options.groundtruth);
  return sequence;
}

void Sequence::LoadBagFrame(size_t index, Frame* frame) const {
  bag_->Load(index, frame->time, &frame->color, &frame->depth_m);
  const std::string where = dir_ + ": frame at t = " + std::to_string(frame->time) + " s";
  if (frame->color.cols != camera_.width || frame->color.rows != camera_.height ||
      frame->depth_m.size() != frame->color.size()) {
    throw InputError(where + ": colour is " + std::to_string(frame->color.cols) + "x" +
                     std::to_string(frame->color.rows) + ", depth " +
                     std::to_string(frame->depth_m.cols) + "x" +
                     std::to_string(frame->depth_m.rows) + ", but the camera is " +
                     std::to_string(camera_.width) + "x" + std::to_string(camera_.height));
  }
}

}  // namespace stillmap
