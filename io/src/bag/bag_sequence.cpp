// Sequence::OpenBag: a recorded bag as a sequence (issue 28).
#include <cmath>
#include <filesystem>

#include "bag/bag_frames.h"
#include "stillmap/io/error.h"
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
    throw InputError(where + ": distortion model " + Quoted(info.distortion_model) + " with " +
                     std::to_string(info.d.size()) +
                     " coefficients is not read (plumb_bob k1 k2 p1 p2 k3, rational_polynomial "
                     "k1 k2 p1 p2 k3 k4 k5 k6); give the camera with --set camera.fx=... "
                     "camera.fy=... camera.cx=... camera.cy=... camera.distortion=...");
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
  auto take = [&](const auto& value, auto& field, const char* key) {
    if (!value) return;
    field = *value;
    given += std::string(given.empty() ? "" : ", ") + key;
  };
  take(overrides.width, camera.width, "camera.width");
  take(overrides.height, camera.height, "camera.height");
  take(overrides.fx, camera.fx, "camera.fx");
  take(overrides.fy, camera.fy, "camera.fy");
  take(overrides.cx, camera.cx, "camera.cx");
  take(overrides.cy, camera.cy, "camera.cy");
  take(overrides.distortion, camera.distortion, "camera.distortion");
  if (overrides.distortion) camera.rational = {};  // the given k1..k3 model replaces the bag's
  take(overrides.depth_factor, camera.depth_factor, "camera.depth_factor");
  if (!given.empty()) notes->push_back(given + " given: used instead of the bag's CameraInfo");
  return camera;
}

// Depth with a camera of its own (its CameraInfo differs from colour's) is registered into colour
// through /tf_static; none is needed when it shares colour's camera.
std::unique_ptr<DepthRegistration> RegistrationOf(const BagContents& contents,
                                                  const BagStream& depth, const BagStream& info,
                                                  const std::string& path,
                                                  std::vector<std::string>* notes) {
  const std::string depth_info = CameraInfoTopicOf(depth.name);
  const BagStream* own = nullptr;
  for (const BagStream& stream : contents.streams) {
    if (stream.name == depth_info && stream.has_info && !SameCamera(stream.info, info.info)) {
      own = &stream;
    }
  }
  if (own == nullptr) return nullptr;
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

}  // namespace

bool IsBag(const std::string& path) { return LooksLikeBag(path); }

std::string DescribeBagTopics(const std::string& path, const SequenceOptions& options) {
  std::unique_ptr<BagReader> reader = stillmap::OpenBag(path);
  const BagContents contents = ScanBagContents(*reader);
  std::string text = "topics:\n" + DescribeBagStreams(contents);
  for (const std::string& warning : contents.warnings) text += "warning: " + warning + "\n";
  try {
    const BagChoice choice = ChooseBagStreams(
        contents, {options.color_topic, options.depth_topic, options.camera_info_topic}, path);
    text += "would use: colour " + contents.streams[choice.color].name + ", depth " +
            contents.streams[choice.depth].name + ", camera " +
            contents.streams[choice.camera_info].name + "\n";
  } catch (const InputError& error) {
    const std::string what = error.what();
    text += "would refuse: " + what.substr(0, what.find(';')) + "\n";
  }
  return text;
}

Sequence Sequence::OpenBag(const std::string& path, const CameraOverrides& overrides,
                           const SequenceOptions& options) {
  if (!(options.max_pair_time_difference > 0.0)) {
    throw InputError("sequence.max_pair_time_difference must be positive");
  }
  std::unique_ptr<BagReader> reader = stillmap::OpenBag(path);
  const BagContents contents = ScanBagContents(*reader);
  const BagChoice choice = ChooseBagStreams(
      contents, {options.color_topic, options.depth_topic, options.camera_info_topic}, path);
  const BagStream& color = contents.streams[choice.color];
  const BagStream& depth = contents.streams[choice.depth];
  const BagStream& info = contents.streams[choice.camera_info];
  std::vector<std::string> notes;
  std::unique_ptr<DepthRegistration> registration =
      RegistrationOf(contents, depth, info, path, &notes);
  Sequence sequence;
  sequence.dir_ = path;
  sequence.options_ = options;
  sequence.warnings_ = contents.warnings;
  sequence.notes_ = notes;
  sequence.notes_.push_back("topics: colour " + color.name + ", depth " + depth.name + ", camera " +
                            info.name);
  Camera camera = overrides.preset.empty() ? CameraFromInfo(info.info, path + ": " + info.name)
                                           : CameraPreset(overrides.preset);
  if (!overrides.preset.empty()) {
    sequence.notes_.push_back("camera.preset=" + overrides.preset +
                              " given: used instead of the bag's CameraInfo");
  }
  camera = WithOverrides(camera, overrides, &sequence.notes_);
  camera.Validate(path + ": " + info.name);
  sequence.camera_ = camera;
  auto frames =
      std::make_shared<BagFrames>(std::move(reader), color, depth, 1.0 / camera.depth_factor);
  if (registration != nullptr) frames->RegisterDepth(std::move(registration));
  frames->Pair(color, depth, options.max_pair_time_difference, &sequence.frames_);
  sequence.color_count_ = color.count;
  sequence.depth_count_ = depth.count;
  sequence.bag_ = std::move(frames);
  if (sequence.frames_.empty()) {
    throw InputError(path + ": no colour message on " + color.name + " has a depth message on " +
                     depth.name + " within " + std::to_string(options.max_pair_time_difference) +
                     " s of its header stamp");
  }
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
