#include "stillmap/viewer/build_folder.h"

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "stillmap/io/cloud_files.h"
#include "stillmap/io/error.h"
#include "stillmap/io/image_io.h"
#include "stillmap/io/input_files.h"
#include "stillmap/io/sequence.h"
#include "stillmap/io/trajectory.h"
#include "stillmap/mapping/occupancy_grid.h"

namespace stillmap {

RenderInput ReadBuildFolder(const std::string& out_dir) {
  namespace fs = std::filesystem;
  const fs::path out(out_dir);
  if (!PathExists((out / "map.ply").string())) {
    throw InputError(out_dir + ": no map.ply here; give the folder a 'stillmap build' wrote");
  }
  RenderInput input;
  input.cloud = ReadCloud((out / "map.ply").string());
  if (PathExists((out / "grid.yaml").string())) input.grid = ReadGrid((out / "grid.yaml").string());
  for (const char* name : {"trajectory.txt", "keyframes.txt"}) {
    if (!PathExists((out / name).string())) continue;
    std::vector<Eigen::Isometry3d>& poses =
        std::string(name) == "trajectory.txt" ? input.trajectory : input.keyframes;
    poses = WorldFromCameras(Trajectory::ReadTum((out / name).string()).poses());
  }
  std::error_code error;
  if (fs::is_regular_file(out / "report.json", error)) {  // only a caption: skipped when odd
    try {
      std::ifstream in(out / "report.json");
      const nlohmann::json report = nlohmann::json::parse(in);
      input.title = SequenceName(report.value("sequence", std::string()));
    } catch (const nlohmann::json::exception&) {
      // The title is only a caption; a damaged report does not stop the renders.
    }
  }
  return input;
}

std::vector<std::string> RenderBuildFolder(const std::string& out_dir) {
  namespace fs = std::filesystem;
  const fs::path out(out_dir);
  const RenderInput input = ReadBuildFolder(out_dir);
  fs::create_directories(out / "renders");
  std::vector<std::string> written;
  for (const auto& [name, image] : RenderViews(input)) {
    WriteImageAtomically((out / "renders" / name).string(), image);
    written.push_back((out / "renders" / name).string());
  }
  return written;
}

}  // namespace stillmap
