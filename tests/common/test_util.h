// Helpers shared by the test programs: temporary folders, synthetic TUM sequences with exact
// geometry, the location of the real data, and running the stillmap binary.
#pragma once

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <functional>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "stillmap/io/camera.h"
#include "stillmap/io/trajectory.h"

namespace stillmap {
namespace testing {

// A folder under the system temp dir, removed with everything in it on destruction.
class TempDir {
 public:
  TempDir();
  ~TempDir();
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  const std::string& path() const { return path_; }
  std::string operator/(const std::string& name) const { return path_ + "/" + name; }

 private:
  std::string path_;
};

// The folder of the real sequences ($STILLMAP_DATA, else ../shared/data), or nullopt when the
// named sequence is absent there.
std::optional<std::string> SharedSequence(const std::string& name);
// A recorded bag of the shared data's bags/ folder, or nullopt when absent.
std::optional<std::string> SharedBag(const std::string& name);
// A tool of the shared folder (tools/NAME beside data/, e.g. make-bags), or nullopt when absent.
std::optional<std::string> SharedTool(const std::string& name);

// An analytic scene: the plane n . X = d (world frame), textured by a checkerboard.
struct PlaneScene {
  Eigen::Vector3d normal = Eigen::Vector3d(0, 0, -1);  // unit, world frame
  double distance = -2.0;                              // n . X = d, i.e. z = 2 m by default
};

// Writes a TUM-layout sequence viewing `scene` from the given camera-to-world poses at 30 Hz:
// rgb/ (PNG), depth/ (16-bit PNG, ray-plane depth exactly quantized), rgb.txt, depth.txt,
// groundtruth.txt and camera.yaml. Returns the poses written (time-stamped).
Trajectory WritePlaneSequence(const std::string& dir, const Camera& camera, const PlaneScene& scene,
                              const std::vector<Eigen::Isometry3d>& world_from_camera);

// Four frames of the default plane seen by SmallCamera(), 1 cm apart along x, with ground truth:
// the smallest sequence every command accepts (the bad-input and reliability tests change it).
void WriteSmallPlaneSequence(const std::string& dir);

// The folder of the detector models ($STILLMAP_MODELS, else ../shared/models), or nullopt when
// it has no subfolder `name` (e.g. "yolox_nano").
std::optional<std::string> SharedModels(const std::string& name);

// A camera without distortion, 64x48 by default (tests stay fast).
Camera SmallCamera(int width = 64, int height = 48);

// Writes a text file.
void WriteText(const std::string& path, const std::string& text);
std::string ReadText(const std::string& path);

// A shortest 8-connected path over `passable` cells (row-major, width x height; diagonal steps
// only between two passable neighbours) from `start` to `goal` by A*, both ends included; empty
// when there is none or an end is not passable.
std::vector<cv::Point> PlanPath(const std::vector<bool>& passable, int width, int height,
                                cv::Point start, cv::Point goal);

// Runs a shell command; returns its exit status and puts its stderr and stdout in `output`.
int RunCommand(const std::string& command, std::string* output);

// Runs the stillmap binary with `arguments` (shell-quoted here); returns its exit status and puts
// stderr (and stdout) in `output`.
// `prefix` runs it under another command (xvfb-run -a).
int RunStillmap(const std::string& arguments, std::string* output, const std::string& prefix = "");

// The message of the InputError `call` throws, or "" when it throws none.
std::string ErrorOf(const std::function<void()>& call);

// A fixture for the tests that run the binary on a small sequence: WriteSmallPlaneSequence in
// dir_/seq (sequence_), builds going to dir_/out (output_).
class SmallSequenceTest : public ::testing::Test {
 protected:
  void SetUp() override { WriteSmallPlaneSequence(sequence_); }
  // `stillmap build SEQUENCE -o OUT --poses groundtruth --quiet EXTRA`: its exit status, and its
  // terminal output in *output.
  int Build(const std::string& extra, std::string* output) const {
    return RunStillmap(
        "build " + sequence_ + " -o " + output_ + " --poses groundtruth --quiet " + extra, output);
  }

  TempDir dir_;
  std::string sequence_ = dir_ / "seq";
  std::string output_ = dir_ / "out";
};

}  // namespace testing
}  // namespace stillmap
