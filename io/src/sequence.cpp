#include "stillmap/io/sequence.h"

#include <fmt/format.h>

#include <algorithm>
#include <filesystem>

#include "stillmap/io/error.h"
#include "stillmap/io/file_list.h"
#include "stillmap/io/image_io.h"
#include "stillmap/io/input_files.h"
#include "stillmap/io/option_names.h"

namespace stillmap {

namespace fs = std::filesystem;

Camera ResolveCamera(const std::string& sequence_dir, const CameraOverrides& overrides) {
  Camera camera;
  const fs::path yaml = fs::path(sequence_dir) / "camera.yaml";
  std::string source;
  if (!overrides.preset.empty()) {
    camera = CameraPreset(overrides.preset);
    source = fmt::format("{}=", OptionKey(&CameraOverrides::preset)) + overrides.preset;
  } else if (PathExists(yaml.string())) {
    camera = LoadCameraYaml(yaml.string());
    source = yaml.string();
  } else if (overrides.fx && overrides.fy && overrides.cx && overrides.cy) {
    source = "camera keys";
  } else {
    throw InputError(sequence_dir +
                     fmt::format(": no camera.yaml; name the camera with --set {}=",
                                 OptionKey(&CameraOverrides::preset)) +
                     CameraPresetChoices() +
                     fmt::format(", or give {}, {}, {} "
                                 "and {}",
                                 OptionKey(&CameraOverrides::fx), OptionKey(&CameraOverrides::fy),
                                 OptionKey(&CameraOverrides::cx), OptionKey(&CameraOverrides::cy)));
  }
  if (overrides.width) camera.width = *overrides.width;
  if (overrides.height) camera.height = *overrides.height;
  if (overrides.fx) camera.fx = *overrides.fx;
  if (overrides.fy) camera.fy = *overrides.fy;
  if (overrides.cx) camera.cx = *overrides.cx;
  if (overrides.cy) camera.cy = *overrides.cy;
  if (overrides.distortion) camera.distortion = *overrides.distortion;
  if (overrides.depth_factor) camera.depth_factor = *overrides.depth_factor;
  camera.Validate(source);
  return camera;
}

Sequence Sequence::Open(const std::string& dir, const Camera& camera,
                        const SequenceOptions& options) {
  std::error_code error;
  if (!fs::is_directory(dir, error)) {
    throw InputError(dir +
                     ": sequence folder not found (expected a TUM-layout folder with "
                     "rgb.txt and depth.txt)");
  }
  if (!(options.max_pair_time_difference > 0.0)) {
    throw InputError(
        fmt::format("{} must be positive", OptionKey(&SequenceOptions::max_pair_time_difference)));
  }
  Sequence sequence;
  sequence.dir_ = dir;
  sequence.camera_ = camera;
  sequence.options_ = options;
  const std::vector<StampedPath> colors = ReadFileList((fs::path(dir) / "rgb.txt").string());
  const std::vector<StampedPath> depths = ReadFileList((fs::path(dir) / "depth.txt").string());
  sequence.color_count_ = colors.size();
  sequence.depth_count_ = depths.size();
  std::vector<double> color_times, depth_times;
  for (const StampedPath& entry : colors) color_times.push_back(entry.time);
  for (const StampedPath& entry : depths) depth_times.push_back(entry.time);
  for (const auto& [c, d] :
       AssociateTimestamps(color_times, depth_times, options.max_pair_time_difference)) {
    FrameEntry frame;
    frame.time = colors[c].time;
    frame.depth_time = depths[d].time;
    frame.color_path = (fs::path(dir) / colors[c].path).string();
    frame.depth_path = (fs::path(dir) / depths[d].path).string();
    sequence.frames_.push_back(frame);
  }
  if (sequence.frames_.empty()) {
    throw InputError(dir + ": no color image has a depth image within " +
                     std::to_string(options.max_pair_time_difference) +
                     " s (compare the timestamps of rgb.txt and depth.txt)");
  }
  const std::string groundtruth = options.groundtruth.empty()
                                      ? (fs::path(dir) / "groundtruth.txt").string()
                                      : options.groundtruth;
  if (!options.groundtruth.empty() || PathExists(groundtruth)) {
    sequence.ReadGroundtruth(groundtruth);
  }
  return sequence;
}

void Sequence::ReadGroundtruth(const std::string& path) {
  const auto holds_a_pose = [](const std::string& line) {
    const std::vector<std::string> fields = SplitFields(line);
    return !fields.empty() && fields[0][0] != '#';
  };
  const std::vector<std::string> lines = ReadTextLines(path, "ground truth");
  if (std::none_of(lines.begin(), lines.end(), holds_a_pose)) {
    groundtruth_note_ = path + " holds no poses";
    return;
  }
  Trajectory trajectory = Trajectory::ReadTum(path);
  if (camera_.groundtruth_body_from_camera) {
    trajectory = trajectory.RightMultiplied(*camera_.groundtruth_body_from_camera);
  }
  groundtruth_ = std::move(trajectory);
}

Frame Sequence::LoadFrame(size_t index) const {
  const FrameEntry& entry = frames_.at(index);
  Frame frame;
  frame.index = index;
  frame.time = entry.time;
  if (bag_) {
    LoadBagFrame(index, &frame);
    return frame;
  }
  frame.color = ReadColorImage(entry.color_path);
  frame.depth_m = ReadDepthImage(entry.depth_path, camera_.depth_factor);
  auto check_size = [&](const cv::Mat& image, const std::string& path) {
    if (image.cols != camera_.width || image.rows != camera_.height) {
      throw InputError(path + ": image is " + std::to_string(image.cols) + "x" +
                       std::to_string(image.rows) + " but the camera is " +
                       std::to_string(camera_.width) + "x" + std::to_string(camera_.height));
    }
  };
  check_size(frame.color, entry.color_path);
  check_size(frame.depth_m, entry.depth_path);
  return frame;
}

std::string SequenceName(const std::string& sequence_dir) {
  fs::path path(sequence_dir);
  if (path.filename().empty()) path = path.parent_path();  // a trailing separator
  return path.filename().string();
}

}  // namespace stillmap
