#include "stillmap/pipeline/config.h"

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <sstream>
#include <utility>

#include "config_values.h"
#include "stillmap/io/error.h"
#include "stillmap/io/option_fields.h"
#include "stillmap/io/option_names.h"
#include "stillmap/io/yaml_file.h"

namespace stillmap {
namespace {

// Keys of earlier releases, still accepted (config files and scripts written for them).
const std::map<std::string, std::string>& FormerKeys() {
  static const std::map<std::string, std::string> kFormer = {
      {"mapping.voxel_leaf", "mapping.voxel_leaf_size"},
      {"mapping.min_points_per_voxel", "mapping.voxel_min_points"},
      {"mapping.view_margin", "mapping.view_margin_m"},
      {"tracking.search_radius", "tracking.search_radius_px"},
      {"tracking.wide_search_radius", "tracking.wide_search_radius_px"},
      {"masking.depth_difference", "masking.max_depth_difference_m"},
      {"masking.grow_depth_difference", "masking.grow_depth_difference_m"},
      {"masking.flow_epsilon_px", "masking.flow_dbscan_epsilon_px"},
      {"masking.flow_min_points", "masking.flow_dbscan_min_points"},
      {"masking.flow_min_epipolar_px", "masking.flow_min_epipolar_distance_px"},
      {"keyframes.selection", "keyframes.enabled"},
  };
  return kFormer;
}

// Every key of a configuration with its help and its value there.
class KeyLister : public OptionVisitor<KeyLister> {
 public:
  struct Entry {
    std::string key;
    std::string help;
    std::optional<std::string> value;  // std::nullopt: unset
  };

  template <typename T>
  void operator()(const char* name, const T& field, const char* help) {
    entries_.push_back({KeyOf(name), help, FormatValue(field)});
  }

  std::vector<Entry> Take() { return std::move(entries_); }

 private:
  std::vector<Entry> entries_;
};

std::vector<KeyLister::Entry> ListEntries(const BuildConfig& config) {
  KeyLister lister;
  BuildConfig::VisitFields(config, lister);
  return lister.Take();
}

// Sets the field under one key.
class KeySetter : public OptionVisitor<KeySetter> {
 public:
  // `key`: the current name of the key the setting was given under.
  KeySetter(const std::string& key, const ConfigSetting& setting) : key_(key), setting_(setting) {}

  template <typename T>
  void operator()(const char* name, T& field, const char* /*help*/) {
    if (found_ || KeyOf(name) != key_) return;
    ParseValue(setting_, &field);
    found_ = true;
  }

  bool found() const { return found_; }

 private:
  const std::string& key_;
  const ConfigSetting& setting_;
  bool found_ = false;
};

// Names the keys of the section the unknown key is in (or the sections, when that is unknown too).
[[noreturn]] void UnknownKey(const std::string& key, const std::string& where) {
  const std::string section = key.substr(0, key.find('.'));
  std::string known, sections;
  for (const KeyLister::Entry& entry : ListEntries(BuildConfig{})) {
    const std::string entry_section = entry.key.substr(0, entry.key.find('.'));
    if (entry_section == section) known += " " + entry.key;
    if (sections.find(" " + entry_section + ".") == std::string::npos) {
      sections += " " + entry_section + ".*";
    }
  }
  throw InputError(fmt::format(
      "{}: unknown configuration key '{}' ({}:{}; `stillmap build --help` "
      "lists every key)",
      where, key, known.empty() ? "sections" : "known", known.empty() ? sections : known));
}

// Checks of string values that only a component can make, at the place they were given.
void CheckSetValue(const BuildConfig& config, const std::string& key,
                   const ConfigSetting& setting) {
  if (key == OptionKey(config, config.camera.preset) && !setting.text.empty()) {
    CameraPreset(setting.text);  // throws for an unknown name
  } else if (key == OptionKey(config, config.detector_levels)) {
    try {
      MotionLevels(config);
    } catch (const InputError& e) {
      throw InputError(setting.where + ": " + key + ": " + e.what());
    }
  }
}

void Flatten(const YAML::Node& node, const std::string& prefix, const std::string& path,
             std::vector<std::pair<std::string, YAML::Node>>* out) {
  for (const auto& item : node) {
    const std::string name = (prefix.empty() ? "" : prefix + ".") + item.first.as<std::string>();
    if (item.second.IsMap()) {
      Flatten(item.second, name, path, out);
    } else {
      out->emplace_back(name, item.second);
    }
  }
}

// A box detector's thresholds and input size.
template <typename Network>
void CheckNetworkOptions(const Network& network) {
  const OptionKeys key(network);
  if (!(network.score_threshold > 0.0 && network.score_threshold < 1.0)) {
    throw InputError(key(network.score_threshold) + " must be in (0, 1)");
  }
  if (!(network.nms_threshold > 0.0 && network.nms_threshold <= 1.0)) {
    throw InputError(key(network.nms_threshold) + " must be in (0, 1]");
  }
  // The network's cost grows with its input: 1280 px is 3x a 640x480 frame's size.
  for (const int size : {network.input_width, network.input_height}) {
    if (size < 32 || size > 1280 || size % 32 != 0) {
      throw InputError(key(network.input_width) + " and " + key(network.input_height) +
                       " must be multiples of 32 in 32..1280");
    }
  }
}

// Records each field under every struct that encloses it, with its offset there.
class KeyRecorder : public OptionVisitor<KeyRecorder> {
 public:
  template <typename Options>
  void EnterStruct(Options& options) {
    enclosing_.emplace_back(typeid(Options), reinterpret_cast<const char*>(&options));
  }
  void LeaveStruct() { enclosing_.pop_back(); }

  template <typename T>
  void operator()(const char* name, const T& field, const char* /*help*/) {
    const char* at = reinterpret_cast<const char*>(&field);
    for (const auto& [type, base] : enclosing_) RegisterOptionKey(type, at - base, KeyOf(name));
  }

 private:
  std::vector<std::pair<std::type_index, const char*>> enclosing_;
};

}  // namespace

void MergeOptions::Validate() const {
  if (place_candidates < 1)
    throw InputError(fmt::format("{} must be at least 1", OptionKey(*this, place_candidates)));
  if (place_min_votes < 1)
    throw InputError(fmt::format("{} must be at least 1", OptionKey(*this, place_min_votes)));
  if (max_descriptor_distance < 0 || max_descriptor_distance > 256) {
    throw InputError(fmt::format("{} must be 0..256", OptionKey(*this, max_descriptor_distance)));
  }
  if (!(match_ratio > 0.0 && match_ratio <= 1.0)) {
    throw InputError(fmt::format("{} must be in (0, 1]", OptionKey(*this, match_ratio)));
  }
  if (min_inliers < 6)
    throw InputError(fmt::format("{} must be at least 6", OptionKey(*this, min_inliers)));
  if (min_links < 1)
    throw InputError(fmt::format("{} must be at least 1", OptionKey(*this, min_links)));
  if (!(agreement_m > 0.0) || !(agreement_deg > 0.0 && agreement_deg <= 180.0)) {
    throw InputError(fmt::format("{} must be > 0 and {} in (0, 180]", OptionKey(*this, agreement_m),
                                 OptionKey(*this, agreement_deg)));
  }
  if (neighbour_edges < 0)
    throw InputError(fmt::format("{} must be >= 0", OptionKey(*this, neighbour_edges)));
  if (!(neighbour_radius_m >= 0.0))
    throw InputError(fmt::format("{} must be >= 0", OptionKey(*this, neighbour_radius_m)));
  if (!(max_seen_share >= 0.0 && max_seen_share <= 1.0)) {
    throw InputError(fmt::format("{} must be in [0, 1]", OptionKey(*this, max_seen_share)));
  }
  if (!(link_weight > 0.0 && link_weight < 1e6)) {
    throw InputError(
        fmt::format("{} must be positive (and below 1e6)", OptionKey(*this, link_weight)));
  }
}

void DenseRefinementOptions::Validate() const {
  if (next_keyframes < 0 || next_keyframes > 16 || revisit_pairs < 0 || revisit_pairs > 16) {
    throw InputError(fmt::format("{} and {} must be 0..16", OptionKey(*this, next_keyframes),
                                 OptionKey(*this, revisit_pairs)));
  }
  if (cell_px < 1 || cell_px > 64)
    throw InputError(fmt::format("{} must be 1..64", OptionKey(*this, cell_px)));
  if (coarse_cell_px != 0 && (coarse_cell_px <= cell_px || coarse_cell_px > 64)) {
    throw InputError(
        fmt::format("{} must be 0 (no coarse alignment) or more than {} and at most 64",
                    OptionKey(*this, coarse_cell_px), OptionKey(*this, cell_px)));
  }
  if (max_span_keyframes < 2 || max_span_keyframes > 1024)
    throw InputError(fmt::format("{} must be 2..1024", OptionKey(*this, max_span_keyframes)));
  if (!(span_sigma_m > 0.0 && span_sigma_m < 1.0))
    throw InputError(fmt::format("{} must be in (0, 1)", OptionKey(*this, span_sigma_m)));
  if (!(span_rotation_sigma_deg > 0.0 && span_rotation_sigma_deg < 90.0))
    throw InputError(
        fmt::format("{} must be in (0, 90)", OptionKey(*this, span_rotation_sigma_deg)));
  if (!(alignment_sigma_m > 0.0 && alignment_sigma_m < 1.0))
    throw InputError(fmt::format("{} must be in (0, 1)", OptionKey(*this, alignment_sigma_m)));
  for (const double* value :
       {&max_next_gap_s, &revisit_min_gap_s, &revisit_max_distance_m, &revisit_max_angle_deg,
        &max_change_m, &max_change_deg, &revisit_max_change_m, &revisit_max_change_deg,
        &cycle_max_m, &cycle_max_deg, &prior_sigma_m, &span_drift_share,
        &span_rotation_drift_deg_per_m, &frame_smoothing_s, &anew_sigma_m}) {
    if (!(*value >= 0.0 && std::isfinite(*value)))
      throw InputError(fmt::format("{} must be >= 0", OptionKey(*this, *value)));
  }
}

void RegisterConfigKeys() {
  static const bool kRegistered = [] {
    const BuildConfig config;
    KeyRecorder recorder;
    recorder.Root(config);
    return true;
  }();
  static_cast<void>(kRegistered);
}

void BuildConfig::Validate() const {
  RegisterConfigKeys();
  ParseGivenPoseSource(run.poses, OptionKey(*this, run.poses));  // throws for "tf:" alone
  poses.Validate();
  const std::vector<std::string> detectors = {
      "auto", "none", "yolo-fastest", "yolox", "yolo-fastest+yolox", "deeplab", "both"};
  if (std::find(detectors.begin(), detectors.end(), run.detector) == detectors.end()) {
    throw InputError(
        fmt::format("{} must be auto, none, yolo-fastest, yolox, yolo-fastest+yolox, deeplab or "
                    "both, not '",
                    OptionKey(*this, run.detector)) +
        run.detector + "'");
  }
  if (run.threads < 1 || run.threads > 64)
    throw InputError(fmt::format("{} must be 1..64", OptionKey(*this, run.threads)));
  if (map.frame != "floor" && map.frame != "camera" && map.frame != "groundtruth" &&
      map.frame != "poses") {
    throw InputError(fmt::format("{} must be floor, camera, groundtruth or poses, not '",
                                 OptionKey(*this, map.frame)) +
                     map.frame + "'");
  }
  if (map.frame == "poses" && (run.poses == "tracking" || run.poses == "groundtruth")) {
    throw InputError(fmt::format(
        "{}=poses puts the map in the given poses' world, but {} is {}; give the poses (a "
        "trajectory file, tf:FRAME or odom:TOPIC), or use {}=groundtruth",
        OptionKey(*this, map.frame), OptionKey(*this, run.poses), run.poses,
        OptionKey(*this, map.frame)));
  }
  // Association looks at every pair within the window: beyond a second it pairs wrong frames and
  // its candidates grow with the square of the frame rate.
  if (!(sequence.max_pair_time_difference > 0.0 && sequence.max_pair_time_difference <= 1.0)) {
    throw InputError(
        fmt::format("{} must be in (0, 1] s", OptionKey(*this, sequence.max_pair_time_difference)));
  }
  if (!(sequence.max_groundtruth_gap > 0.0)) {
    throw InputError(
        fmt::format("{} must be positive", OptionKey(*this, sequence.max_groundtruth_gap)));
  }
  if (!(ate.max_time_difference > 0.0 && ate.max_time_difference <= 1.0)) {
    throw InputError(
        fmt::format("{} must be in (0, 1] s", OptionKey(*this, ate.max_time_difference)));
  }
  if (!(rpe.delta > 0.0))
    throw InputError(fmt::format("{} must be > 0", OptionKey(*this, rpe.delta)));
  if (groundtruth_reference_interval < 1 || groundtruth_reference_interval > 1000) {
    throw InputError(
        fmt::format("{} must be 1..1000 frames", OptionKey(*this, groundtruth_reference_interval)));
  }
  mapping.Validate();
  tracking.Validate();
  masking.Validate();
  merge.Validate();
  final_poses.Validate();
  trajectory_smoothing.Validate();
  selection.Validate();
  grid.Validate();
  mesh.Validate();
  CheckNetworkOptions(yolox);
  CheckNetworkOptions(fastest);
  const int coarse_width = fastest.coarse_input_width, coarse_height = fastest.coarse_input_height;
  const bool coarse_valid = coarse_width >= 32 && coarse_width <= fastest.input_width &&
                            coarse_height >= 32 && coarse_height <= fastest.input_height &&
                            coarse_width % 32 == 0 && coarse_height % 32 == 0;
  if (!(coarse_width == 0 && coarse_height == 0) && !coarse_valid) {
    throw InputError(
        fmt::format("{} and {} must both "
                    "be 0 (no coarse pass) or multiples of 32 from 32 up to the first pass's size",
                    OptionKey(*this, fastest.coarse_input_width),
                    OptionKey(*this, fastest.coarse_input_height)));
  }
  if (render.width < 64 || render.width > 4096 || render.height < 64 || render.height > 4096) {
    throw InputError(fmt::format("{} and {} must be 64..4096 px", OptionKey(*this, render.width),
                                 OptionKey(*this, render.height)));
  }
  if (!(deeplab.min_segment_share >= 0.0 && deeplab.min_segment_share < 1.0)) {
    throw InputError(
        fmt::format("{} must be in [0, 1)", OptionKey(*this, deeplab.min_segment_share)));
  }
}

MotionLevelTable MotionLevels(const BuildConfig& config) {
  MotionLevelTable table = MotionLevelTable::Default();
  std::stringstream entries(config.detector_levels);
  std::string entry;
  while (std::getline(entries, entry, ',')) {
    if (entry.empty()) continue;
    const size_t equals = entry.find('=');
    if (equals == std::string::npos || equals == 0) {
      throw InputError("'" + entry + "' is not name=level");
    }
    table.Set(entry.substr(0, equals), entry.substr(equals + 1));
  }
  return table;
}

std::vector<ConfigKeyInfo> ListConfigKeys() {
  RegisterConfigKeys();
  std::vector<ConfigKeyInfo> infos;
  for (KeyLister::Entry& entry : ListEntries(BuildConfig{})) {
    infos.push_back({entry.key, entry.help, entry.value.value_or("")});
  }
  return infos;
}

void SetConfigValue(BuildConfig* config, const std::string& key, const std::string& value,
                    const std::string& where) {
  RegisterConfigKeys();
  const auto former = FormerKeys().find(key);
  const std::string& current = former == FormerKeys().end() ? key : former->second;
  const ConfigSetting setting{key, value, where};
  KeySetter setter(current, setting);
  BuildConfig::VisitFields(*config, setter);
  if (!setter.found()) UnknownKey(key, where);
  CheckSetValue(*config, current, setting);
}

void ApplySetArgument(BuildConfig* config, const std::string& argument) {
  const size_t equals = argument.find('=');
  if (equals == std::string::npos || equals == 0) {
    throw InputError("--set " + argument +
                     fmt::format(": expected key=value, e.g. --set {}=0.02",
                                 OptionKey(&VoxelCloudOptions::leaf_size)));
  }
  SetConfigValue(config, argument.substr(0, equals), argument.substr(equals + 1), "--set");
}

void ApplyConfigFile(BuildConfig* config, const std::string& path) {
  const YAML::Node root = LoadYamlFile(path, "configuration file");
  if (root.IsNull()) return;
  if (!root.IsMap()) throw InputError(path + ": expected a YAML map of configuration keys");
  std::vector<std::pair<std::string, YAML::Node>> entries;
  Flatten(root, "", path, &entries);
  for (const auto& [name, node] : entries) {
    const std::string where = WhereInFile(path, node.Mark().line + 1);
    std::string value;
    if (node.IsSequence()) {
      for (const YAML::Node& item : node) {
        if (!item.IsScalar()) {
          throw InputError(
              fmt::format("{}: key '{}' must hold a value or a list of values", where, name));
        }
        if (!value.empty()) value += ',';
        value += item.Scalar();
      }
    } else if (node.IsScalar()) {
      value = node.as<std::string>();
    } else if (!node.IsNull()) {
      throw InputError(fmt::format("{}: key '{}' must hold a value", where, name));
    }
    SetConfigValue(config, name, value, where);
  }
}

std::string ConfigToYaml(const BuildConfig& config) {
  // Keys grouped by section, sections in the order they first appear.
  std::vector<std::pair<std::string, std::string>> sections;  // name, lines
  for (const KeyLister::Entry& entry : ListEntries(config)) {
    const size_t dot = entry.key.find('.');
    const std::string section = entry.key.substr(0, dot), name = entry.key.substr(dot + 1);
    auto it = std::find_if(sections.begin(), sections.end(),
                           [&](const auto& s) { return s.first == section; });
    if (it == sections.end()) it = sections.insert(sections.end(), {section, ""});
    // An unset value (a camera parameter from the sequence's camera.yaml) stays commented out.
    it->second += entry.value ? fmt::format("  {}: {}  # {}\n", name, *entry.value, entry.help)
                              : fmt::format("  # {}:  unset; {}\n", name, entry.help);
  }
  std::string yaml =
      "# stillmap effective configuration; rerun with: stillmap build SEQ -o OUT --config "
      "config.yaml\n";
  for (const auto& [section, lines] : sections) yaml += fmt::format("{}:\n{}", section, lines);
  return yaml;
}

}  // namespace stillmap
