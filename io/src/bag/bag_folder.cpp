#include "bag/bag_folder.h"

#include <algorithm>
#include <cctype>
#include <filesystem>

#include "stillmap/io/error.h"
#include "stillmap/io/yaml_file.h"

namespace stillmap {
namespace fs = std::filesystem;
namespace {

bool IsStorageFile(const fs::path& path) {
  std::error_code error;
  const std::string extension = path.extension().string();
  return (extension == ".db3" || extension == ".mcap") && fs::is_regular_file(path, error);
}

// rosbag2's split files in their order: NAME_2 before NAME_10.
bool BySplitIndex(const fs::path& a, const fs::path& b) {
  auto split = [](const fs::path& path) {
    const std::string stem = path.stem().string();
    size_t digits = stem.size();
    while (digits > 0 && std::isdigit(static_cast<unsigned char>(stem[digits - 1])) != 0) {
      --digits;
    }
    const std::string number = stem.substr(digits);
    return std::make_tuple(stem.substr(0, digits), number.size(), number, path.string());
  };
  return split(a) < split(b);
}

std::string Scalar(const YAML::Node& node, const char* key) {
  const YAML::Node value = node[key];
  return value && value.IsScalar() ? value.Scalar() : std::string();
}

}  // namespace

bool IsBagFolder(const std::string& folder) {
  std::error_code error;
  if (!fs::is_directory(folder, error)) return false;
  if (fs::exists(fs::path(folder) / "rgb.txt", error)) return false;
  if (fs::is_regular_file(fs::path(folder) / "metadata.yaml", error)) return true;
  for (const fs::directory_entry& entry : fs::directory_iterator(folder, error)) {
    if (IsStorageFile(entry.path())) return true;
  }
  return false;
}

BagFolder::BagFolder(const std::string& folder) : BagReader(folder) {
  const fs::path metadata = fs::path(folder) / "metadata.yaml";
  std::error_code error;
  const std::vector<std::string> files =
      fs::is_regular_file(metadata, error) ? FilesFromMetadata(metadata.string()) : FilesByName();
  for (const std::string& file : files) {
    if (!fs::is_regular_file(file, error)) {
      throw InputError(file + ": named by " + metadata.string() +
                       " but not found (or not a file): the bag folder is incomplete");
    }
    parts_.push_back(OpenBag(file));
    if (parts_.back()->serialization() != BagSerialization::kCdr) {
      throw InputError(file + ": a ROS 1 bag inside a ROS 2 bag folder; give it on its own");
    }
    JoinTopics(parts_.size() - 1);
  }
}

std::vector<std::string> BagFolder::FilesFromMetadata(const std::string& metadata) {
  const YAML::Node root = LoadYamlFile(metadata, "ROS 2 bag metadata");
  const YAML::Node info = root.IsMap() ? root["rosbag2_bagfile_information"] : YAML::Node();
  if (!info || !info.IsMap()) {
    throw InputError(metadata + ": no rosbag2_bagfile_information map: not a ROS 2 bag's metadata");
  }
  const std::string storage = Scalar(info, "storage_identifier");
  if (!storage.empty() && storage != "sqlite3" && storage != "mcap") {
    throw InputError(
        metadata + ": storage " + Quoted(storage) +
        " is not read (sqlite3 and mcap are); convert the bag with `ros2 bag convert`");
  }
  const std::string mode = Scalar(info, "compression_mode");
  if (!mode.empty() && mode != "NONE" && mode != "none") {
    throw InputError(metadata + ": compressed by rosbag2 per " + mode + " (" +
                     Scalar(info, "compression_format") +
                     "), which is not read; write an uncompressed copy with `ros2 bag convert` "
                     "(MCAP's own chunk compression is read)");
  }
  std::vector<std::string> files;
  const YAML::Node paths = info["relative_file_paths"];
  if (paths && paths.IsSequence()) {
    for (const YAML::Node& path : paths) {
      if (!path.IsScalar() || path.Scalar().empty()) {
        throw InputError(metadata + ": relative_file_paths holds an entry that is not a file name");
      }
      const std::string file = (fs::path(path_) / path.Scalar()).lexically_normal().string();
      if (std::find(files.begin(), files.end(), file) != files.end()) {
        notes_.push_back(metadata + ": relative_file_paths lists " + Quoted(path.Scalar()) +
                         " more than once; it is read once");
        continue;
      }
      files.push_back(file);
    }
  }
  if (files.empty()) throw InputError(metadata + ": relative_file_paths names no storage file");
  return files;
}

std::vector<std::string> BagFolder::FilesByName() {
  std::vector<fs::path> found;
  std::error_code error;
  for (const fs::directory_entry& entry : fs::directory_iterator(path_, error)) {
    if (IsStorageFile(entry.path())) found.push_back(entry.path());
  }
  if (found.empty()) {
    throw InputError(path_ +
                     ": neither metadata.yaml nor a .db3 or .mcap file: not a ROS 2 bag "
                     "folder");
  }
  std::sort(found.begin(), found.end(), BySplitIndex);
  std::vector<std::string> files;
  files.reserve(found.size());
  for (const fs::path& path : found) files.push_back(path.string());
  notes_.push_back(path_ + ": no metadata.yaml (a recording that was not closed?): its " +
                   std::to_string(files.size()) + " storage file(s) are read in name order");
  return files;
}

void BagFolder::JoinTopics(size_t part) {
  std::vector<size_t> indices;
  for (const BagTopic& topic : parts_[part]->topics()) {
    indices.push_back(JoinTopic(&topics_, topic));
  }
  topic_of_part_topic_.resize(parts_.size());
  topic_of_part_topic_[part] = std::move(indices);
}

void BagFolder::Scan(const std::function<void(const BagMessage&)>& visit) {
  warnings_ = notes_;
  truncated_ = false;
  for (size_t part = 0; part < parts_.size(); ++part) {
    parts_[part]->Scan([&](const BagMessage& message) {
      // A file's topics become known as its scan goes (MCAP): join them as they come.
      if (message.topic >= topic_of_part_topic_[part].size()) JoinTopics(part);
      BagMessage joined = message;
      joined.topic = topic_of_part_topic_[part].at(message.topic);
      joined.position.part = static_cast<std::uint32_t>(part);
      visit(joined);
    });
    const std::vector<std::string>& warnings = parts_[part]->warnings();
    warnings_.insert(warnings_.end(), warnings.begin(), warnings.end());
    truncated_ = truncated_ || parts_[part]->truncated();
  }
}

std::vector<std::uint8_t> BagFolder::Read(const BagPosition& position) const {
  if (position.part >= parts_.size()) {
    throw InputError(path_ + ": no storage file " + std::to_string(position.part));
  }
  return parts_[position.part]->Read(position);
}

}  // namespace stillmap
