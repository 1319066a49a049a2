// What the round-3 hostile tests of a user's files and settings share (hostile_user_data_test.cpp,
// hostile_silent_input_test.cpp): a case's folders and its contract, the tracked base sequence,
// and the seeded generator's names, bytes and picks.
#pragma once

#include <gtest/gtest.h>
#include <jpeglib.h>
#include <signal.h>
#include <sys/mount.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <map>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <regex>
#include <set>

#include "hostile_corpus.h"
#include "stillmap/pipeline/config.h"
#include "test_util.h"

namespace stillmap {

inline const size_t kInstances = EnvCount("STILLMAP_HOSTILE_ROUND3", 2);

// One case's folders: a copy of the base sequence and an output folder beside it.
// The base sequence at full size (640x480), for the cases that track the camera: the corpus' small
// base is too small for ORB features.
inline const std::string& TrackedBase() {
  static testing::TempDir dir;
  static const std::string path = [] {
    std::string output;
    const std::string sequence = dir / "base";
    if (testing::RunStillmap("synth " + sequence + " --scenario walking_xyz --frames 12 --seed 3",
                             &output) != 0) {
      throw std::runtime_error("synth failed: " + output);
    }
    return sequence;
  }();
  return path;
}

class Case {
 public:
  explicit Case(bool tracked = false) {
    std::filesystem::copy(tracked ? TrackedBase() : BaseSequence(), sequence,
                          std::filesystem::copy_options::recursive);
  }

  // Runs `arguments` through the binary under the corpus' limits and checks the contract.
  int Run(const std::string& arguments, std::string* output) const {
    const int status = testing::RunStillmap(arguments, output, HostilePrefix());
    EXPECT_TRUE(status == 0 || status == 1 || status == 2)
        << "stillmap " << arguments << "\nexit " << status << "\n"
        << *output;
    for (const std::string& marker : kInternalMarkers) {
      EXPECT_EQ(output->find(marker), std::string::npos)
          << "stillmap " << arguments << "\nlibrary text '" << marker << "':\n"
          << *output;
    }
    if (status == 1 || status == 2) {
      const std::vector<std::string> lines = Lines(*output);
      const std::string expected = status == 2 ? "stillmap: error: " : "stillmap: failed: ";
      EXPECT_TRUE(!lines.empty() && lines.back().rfind(expected, 0) == 0)
          << "stillmap " << arguments << "\n"
          << *output;
    }
    return status;
  }
  int Build(const std::string& extra, std::string* output) const {
    return Run("build " + sequence + " -o " + out + " --quiet --poses groundtruth " + extra,
               output);
  }

  testing::TempDir dir;
  const std::string sequence = dir / "seq";
  const std::string out = dir / "out";
};

inline std::string RandomName(Generator& g, const std::string& extension) {
  std::string name;
  for (size_t i = 0, n = 3 + g.Below(8); i < n; ++i) name += static_cast<char>('a' + g.Below(26));
  return name + extension;
}

inline std::string RandomBytes(Generator& g, size_t size) {
  std::string bytes(size, '\0');
  for (char& byte : bytes) byte = static_cast<char>(g.Below(256));
  return bytes;
}

// The files of `folder`, sorted (directory order differs between file systems; the generator's
// picks must not).
inline std::vector<std::string> FilesIn(const std::string& folder) {
  std::vector<std::string> paths;
  for (const std::filesystem::directory_entry& e : std::filesystem::directory_iterator(folder)) {
    paths.push_back(e.path().string());
  }
  std::sort(paths.begin(), paths.end());
  return paths;
}

inline const std::vector<std::string>& ConfigSections() {
  static const std::vector<std::string> sections = [] {
    std::set<std::string> unique;
    for (const ConfigKeyInfo& key : ListConfigKeys())
      unique.insert(key.name.substr(0, key.name.find('.')));
    return std::vector<std::string>(unique.begin(), unique.end());
  }();
  return sections;
}

}  // namespace stillmap
