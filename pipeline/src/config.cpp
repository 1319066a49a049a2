#include "stillmap/pipeline/config.h"

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <map>
#include <sstream>
#include <utility>

#include "config_values.h"
#include "stillmap/io/error.h"
#include "stillmap/io/option_fields.h"
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
  if (key == "camera.preset" && !setting.text.empty()) {
    CameraPreset(setting.text);  // throws for an unknown name
  } else if (key == "detector.levels") {
    try {
      MotionLevels(config);
    } catch (const InputError& e) {
      throw InputError(setting.where + ": detector.levels: " + e.what());
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

// A box detector's thresholds and input size; `prefix` names their keys.
void CheckNetworkOptions(const std::string& prefix, double score_threshold, double nms_threshold,
                         int input_width, int input_height) {
  if (!(score_threshold > 0.0 && score_threshold < 1.0)) {
    throw InputError(prefix + "score_threshold must be in (0, 1)");
  }
  if (!(nms_threshold > 0.0 && nms_threshold <= 1.0)) {
    throw InputError(prefix + "nms_threshold must be in (0, 1]");
  }
  // The network's cost grows with its input: 1280 px is 3x a 640x480 frame's size.
  for (const int size : {input_width, input_height}) {
    if (size < 32 || size > 1280 || size % 32 != 0) {
      std::string message = prefix + "input_width and ";
      message += prefix + "input_height must be multiples of 32 in 32..1280";
      throw InputError(message);
    }
  }
}

}  // namespace

void MergeOptions::Validate() const {
  if (place_candidates < 1) throw InputError("merge.place_candidates must be at least 1");
  if (place_min_votes < 1) throw InputError("merge.place_min_votes must be at least 1");
  if (max_descriptor_distance < 0 || max_descriptor_distance > 256) {
    throw InputError("merge.max_descriptor_distance must be 0..256");
  }
  if (!(match_ratio > 0.0 && match_ratio <= 1.0)) {
    throw InputError("merge.match_ratio must be in (0, 1]");
  }
  if (min_inliers < 6) throw InputError("merge.min_inliers must be at least 6");
  if (min_links < 1) throw InputError("merge.min_links must be at least 1");
  if (!(agreement_m > 0.0) || !(agreement_deg > 0.0 && agreement_deg <= 180.0)) {
    throw InputError("merge.agreement_m must be > 0 and merge.agreement_deg in (0, 180]");
  }
  if (neighbour_edges < 0) throw InputError("merge.neighbour_edges must be >= 0");
  if (!(neighbour_radius_m >= 0.0)) throw InputError("merge.neighbour_radius_m must be >= 0");
  if (!(max_seen_share >= 0.0 && max_seen_share <= 1.0)) {
    throw InputError("merge.max_seen_share must be in [0, 1]");
  }
  if (!(link_weight > 0.0 && link_weight < 1e6)) {
    throw InputError("merge.link_weight must be positive (and below 1e6)");
  }
}

void BuildConfig::Validate() const {
  if (run.poses != "tracking" && run.poses != "groundtruth") {
    throw InputError("run.poses must be tracking or groundtruth, not '" + run.poses + "'");
  }
  const std::vector<std::string> detectors = {"auto",  "none",    "yolo-fastest",
                                              "yolox", "deeplab", "both"};
  if (std::find(detectors.begin(), detectors.end(), run.detector) == detectors.end()) {
    throw InputError(
        "run.detector must be auto, none, yolo-fastest, yolox, deeplab or both, not '" +
        run.detector + "'");
  }
  if (run.threads < 1 || run.threads > 64) throw InputError("run.threads must be 1..64");
  if (map.frame != "floor" && map.frame != "camera" && map.frame != "groundtruth") {
    throw InputError("map.frame must be floor, camera or groundtruth, not '" + map.frame + "'");
  }
  // Association looks at every pair within the window: beyond a second it pairs wrong frames and
  // its candidates grow with the square of the frame rate.
  if (!(sequence.max_pair_time_difference > 0.0 && sequence.max_pair_time_difference <= 1.0)) {
    throw InputError("sequence.max_pair_time_difference must be in (0, 1] s");
  }
  if (!(sequence.max_groundtruth_gap > 0.0)) {
    throw InputError("sequence.max_groundtruth_gap must be positive");
  }
  if (!(ate.max_time_difference > 0.0 && ate.max_time_difference <= 1.0)) {
    throw InputError("eval.max_time_difference must be in (0, 1] s");
  }
  if (!(rpe.delta > 0.0)) throw InputError("eval.rpe_delta must be > 0");
  if (groundtruth_reference_interval < 1 || groundtruth_reference_interval > 1000) {
    throw InputError("masking.groundtruth_reference_interval must be 1..1000 frames");
  }
  mapping.Validate();
  tracking.Validate();
  masking.Validate();
  merge.Validate();
  selection.Validate();
  grid.Validate();
  mesh.Validate();
  CheckNetworkOptions("detector.", yolox.score_threshold, yolox.nms_threshold, yolox.input_width,
                      yolox.input_height);
  CheckNetworkOptions("detector.fastest_", fastest.score_threshold, fastest.nms_threshold,
                      fastest.input_width, fastest.input_height);
  const int coarse_width = fastest.coarse_input_width, coarse_height = fastest.coarse_input_height;
  const bool coarse_valid = coarse_width >= 32 && coarse_width <= fastest.input_width &&
                            coarse_height >= 32 && coarse_height <= fastest.input_height &&
                            coarse_width % 32 == 0 && coarse_height % 32 == 0;
  if (!(coarse_width == 0 && coarse_height == 0) && !coarse_valid) {
    throw InputError(
        "detector.fastest_coarse_input_width and detector.fastest_coarse_input_height must both "
        "be 0 (no coarse pass) or multiples of 32 from 32 up to the first pass's size");
  }
  if (render.width < 64 || render.width > 4096 || render.height < 64 || render.height > 4096) {
    throw InputError("render.width and render.height must be 64..4096 px");
  }
  if (!(deeplab.min_segment_share >= 0.0 && deeplab.min_segment_share < 1.0)) {
    throw InputError("detector.min_segment_share must be in [0, 1)");
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
  std::vector<ConfigKeyInfo> infos;
  for (KeyLister::Entry& entry : ListEntries(BuildConfig{})) {
    infos.push_back({entry.key, entry.help, entry.value.value_or("")});
  }
  return infos;
}

void SetConfigValue(BuildConfig* config, const std::string& key, const std::string& value,
                    const std::string& where) {
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
                     ": expected key=value, e.g. --set mapping.voxel_leaf_size=0.02");
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
