// What the hostile-input tests share: the small base sequence every variant corrupts a copy of,
// the time limit and sanitizer settings of each run, and the library messages that must never
// reach a user.
#pragma once

#include <cstdlib>
#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <random>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "stillmap/io/camera.h"
#include "test_util.h"

namespace stillmap {

// Settings of the generator and of each run.
inline size_t EnvCount(const char* name, size_t fallback) {
  const char* value = std::getenv(name);
  return value != nullptr && *value != '\0' ? std::stoul(value) : fallback;
}
inline const size_t kSeed = EnvCount("STILLMAP_HOSTILE_SEED", 1);
inline const size_t kVariants = EnvCount("STILLMAP_HOSTILE_VARIANTS", 60);

// A seeded generator of each family's choices (`family` keeps families apart).
class Generator {
 public:
  explicit Generator(size_t family) : rng_(kSeed * 7919 + family) {}
  size_t Below(size_t n) {
    return n == 0 ? 0 : std::uniform_int_distribution<size_t>(0, n - 1)(rng_);
  }
  template <typename T>
  const T& Pick(const std::vector<T>& values) {
    return values[Below(values.size())];
  }
  std::mt19937_64& rng() { return rng_; }

 private:
  std::mt19937_64 rng_;
};

constexpr int kTimeLimitS = 120;  // a run that takes longer hangs (the clean ones take ~1 s)

// The base sequence: 12 frames of people walking past a moving camera, rendered by
// `stillmap synth` and scaled to 160x120 so that a run takes about a second.
inline const std::string& BaseSequence() {
  static testing::TempDir dir;
  static const std::string path = [] {
    const std::string sequence = dir / "base";
    std::string output;
    const int status = testing::RunStillmap(
        "synth " + sequence + " --scenario walking_xyz --frames 12 --seed 3 --threads 1", &output);
    if (status != 0) throw std::runtime_error("synth failed: " + output);
    const double scale = 0.25;
    for (const char* folder : {"rgb", "depth", "masks"}) {
      for (const std::filesystem::directory_entry& entry :
           std::filesystem::directory_iterator(sequence + "/" + folder)) {
        cv::Mat image = cv::imread(entry.path().string(), cv::IMREAD_UNCHANGED);
        cv::resize(image, image, cv::Size(), scale, scale,
                   std::string(folder) == "rgb" ? cv::INTER_AREA : cv::INTER_NEAREST);
        cv::imwrite(entry.path().string(), image);
      }
    }
    Camera camera = LoadCameraYaml(sequence + "/camera.yaml");
    camera.width = 160, camera.height = 120;
    camera.fx *= scale, camera.fy *= scale;
    camera.cx = (camera.cx + 0.5) * scale - 0.5, camera.cy = (camera.cy + 0.5) * scale - 0.5;
    WriteCameraYaml(sequence + "/camera.yaml", camera, "hostile-input base, 1/4 scale");
    return sequence;
  }();
  return path;
}

inline std::vector<std::string> Lines(const std::string& text) {
  std::vector<std::string> lines;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

inline std::string Join(const std::vector<std::string>& lines) {
  std::string text;
  for (const std::string& line : lines) text += line + "\n";
  return text;
}

// Library messages that must not reach the user as the reason a run failed.
inline const std::vector<std::string> kInternalMarkers = {"basic_",
                                                          "std::",
                                                          "bad_alloc",
                                                          "filesystem error",
                                                          "vector::",
                                                          "substr",
                                                          "stoi",
                                                          "stod",
                                                          "OpenCV(",
                                                          "Assertion",
                                                          "yaml-cpp",
                                                          "bad conversion",
                                                          "terminate called",
                                                          "nlohmann",
                                                          "AddressSanitizer",
                                                          "runtime error:",
                                                          "out of OcTree bounds",
                                                          "libpng",
                                                          "libjpeg: Unsupported",
                                                          "database disk image is malformed",
                                                          "file is not a database",
                                                          "no such table",
                                                          "Too many levels of symbolic links",
                                                          "Write Error",
                                                          "bad adaptive filter value",
                                                          "Premature end of JPEG file",
                                                          "Corrupt JPEG data",
                                                          "illegal map value",
                                                          "end of map not found",
                                                          "end of sequence not found",
                                                          "unknown escape character"};

// Each run has a time limit (a hang fails, not blocks), and sanitizer reports end the run
// with a signal instead of exit status 1.
inline std::string HostilePrefix() {
  return "ASAN_OPTIONS=abort_on_error=1:detect_leaks=0 "
         "UBSAN_OPTIONS=halt_on_error=1:abort_on_error=1:print_stacktrace=1 "
         "timeout -s KILL " +
         std::to_string(kTimeLimitS);
}

}  // namespace stillmap
