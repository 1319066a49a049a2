#include "stillmap/pipeline/model_search.h"

#include <cstdlib>
#include <filesystem>

#include "stillmap/tracking/detector.h"

namespace stillmap {
namespace fs = std::filesystem;
namespace {

std::string Environment(const char* name) {
  const char* value = std::getenv(name);
  return value == nullptr ? std::string() : std::string(value);
}

// The running binary's folder (Linux: /proc/self/exe), or "" when it cannot be told.
fs::path BinaryFolder() {
  std::error_code error;
  const fs::path binary = fs::read_symlink("/proc/self/exe", error);
  return error ? fs::path() : binary.parent_path();
}

bool HoldsModel(const fs::path& folder) {
  std::error_code error;
  return HoldsFastest(folder.string()) || HoldsYolox(folder.string()) ||
         fs::is_directory(folder / "deeplabv3_mnv2_voc", error);
}

}  // namespace

std::vector<ModelsFolder> ModelSearchPath() {
  std::vector<ModelsFolder> path;
  if (const std::string models = Environment("STILLMAP_MODELS"); !models.empty()) {
    path.push_back({models, "$STILLMAP_MODELS"});
  }
  fs::path data = Environment("XDG_DATA_HOME");
  if (data.empty() && !Environment("HOME").empty())
    data = fs::path(Environment("HOME")) / ".local/share";
  if (!data.empty()) path.push_back({(data / "stillmap/models").string(), "user data folder"});
  const fs::path binary = BinaryFolder();
  if (!binary.empty()) {
    path.push_back({(binary.parent_path() / "share/stillmap/models").lexically_normal().string(),
                    "install share folder"});
  }
  path.push_back({STILLMAP_INSTALL_MODELS_DIR, "install share folder"});
  if (!binary.empty()) path.push_back({(binary / "models").string(), "beside the binary"});
  path.push_back({"../shared/models", "../shared/models"});
  return path;
}

std::optional<ModelsFolder> FindModels() {
  for (const ModelsFolder& folder : ModelSearchPath()) {
    if (HoldsModel(folder.path)) return folder;
  }
  return std::nullopt;
}

std::string DescribeDefaultDetector() {
  const std::optional<ModelsFolder> found = FindModels();
  if (!found) {
    return "none (geometry only): no models in " + DescribeModelSearchPath() +
           "; scripts/fetch-models gets them";
  }
  return ResolveDetectorName("auto", found->path) + " (models in " + found->path +
         ", found through " + found->found_by + ")";
}

std::string DescribeModelSearchPath() {
  std::string text;
  for (const ModelsFolder& folder : ModelSearchPath()) {
    text += (text.empty() ? "" : ", ") + folder.path;
  }
  return text;
}

std::string ResolveModels(RunSettings* run, const std::string& given_by) {
  if (!run->models.empty()) return given_by;
  if (run->detector == "none") return "";
  const std::optional<ModelsFolder> found = FindModels();
  if (!found) return "";
  run->models = found->path;
  return found->found_by;
}

}  // namespace stillmap
