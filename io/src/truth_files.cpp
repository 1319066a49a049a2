#include "stillmap/io/truth_files.h"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>

#include "stillmap/io/error.h"
#include "stillmap/io/file_list.h"
#include "stillmap/io/image_io.h"
#include "stillmap/io/input_files.h"
#include "stillmap/io/trajectory.h"

namespace stillmap {

namespace fs = std::filesystem;

TruthMasks::TruthMasks(const std::string& sequence_dir) {
  const fs::path list = fs::path(sequence_dir) / "masks.txt";
  if (!PathExists(list.string())) return;
  for (const StampedPath& entry : ReadFileList(list.string())) {
    times_.push_back(entry.time);
    paths_.push_back((fs::path(sequence_dir) / entry.path).string());
  }
}

cv::Mat TruthMasks::Get(double time) const {
  if (times_.empty()) return cv::Mat();
  const size_t i = FindClosestIndex(times_, time);
  if (std::abs(times_[i] - time) > 1e-3) return cv::Mat();
  cv::Mat mask = ReadImageAsStored(paths_[i]);
  if (mask.type() != CV_8UC1) {
    throw InputError(paths_[i] + ": not a readable 8-bit mask PNG (listed in masks.txt)");
  }
  return mask;
}

std::vector<ObjectPose> ReadObjectPoses(const std::string& path) {
  std::vector<ObjectPose> poses;
  int line_number = 0;
  for (const std::string& line : ReadTextLines(path, "object list")) {
    ++line_number;
    const std::vector<std::string> fields = SplitFields(line);
    if (fields.empty() || fields[0][0] == '#') continue;
    const std::string where = WhereInFile(path, line_number);
    double v[10] = {};
    bool numbers = fields.size() == 10;
    for (size_t i = 0; numbers && i < 10; ++i) {
      if (i != 1 && i != 2) numbers = ParseFiniteDouble(fields[i], &v[i]);
    }
    if (!numbers) {
      std::string message = where;
      message += ": expected 'timestamp object_id name tx ty tz qx qy qz qw' with finite numbers, ";
      message += "got '";
      message += Quoted(line);
      message += "'";
      throw InputError(message);
    }
    ObjectPose pose;
    pose.time = v[0];
    pose.id = fields[1];
    pose.name = fields[2];
    pose.world_from_object = PoseFromTumFields(&v[3], where);
    poses.push_back(std::move(pose));
  }
  return poses;
}

}  // namespace stillmap
