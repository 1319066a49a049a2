// Round 4 of the hostile corpus (issue 49) through the binary: what is given where a bag or a
// session belongs (an empty or tiny file, a FIFO, an empty folder, a folder given twice under
// another name), --topic given wrongly, and a merge into a folder holding the user's own map.
// Each ends with a clear line naming the file and what to do, within the time limit.
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <filesystem>
#include <fstream>

#include "hostile_corpus.h"

namespace stillmap {
namespace {

namespace fs = std::filesystem;

class HostileRound4Test : public ::testing::Test {
 protected:
  // Runs `arguments` and expects exit 2 with `expected` in the output, and no library text.
  void ExpectRefused(const std::string& arguments, const std::string& expected) {
    std::string output;
    const std::string quiet = arguments.rfind("info ", 0) == 0 ? "" : " --quiet";
    EXPECT_EQ(testing::RunStillmap(arguments + quiet, &output, HostilePrefix()), 2)
        << arguments << "\n"
        << output;
    EXPECT_NE(output.find(expected), std::string::npos) << arguments << "\n" << output;
    for (const std::string& marker : kInternalMarkers) {
      EXPECT_EQ(output.find(marker), std::string::npos) << arguments << "\n" << output;
    }
  }
  testing::TempDir dir_;
};

TEST_F(HostileRound4Test, WhatIsGivenForABagIsSaid) {
  const std::string empty = dir_ / "empty.bag", tiny = dir_ / "tiny.bag", fifo = dir_ / "fifo.bag";
  std::ofstream(empty).flush();
  std::ofstream(tiny) << "#ROSB";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  fs::create_directories(dir_ / "folder.bag");
  const std::string out = " -o " + (dir_ / "out");
  ExpectRefused("build " + empty + out, empty + ": an empty file (0 bytes)");
  ExpectRefused("build " + tiny + out, tiny + ": a file of 5 bytes that is not a bag");
  ExpectRefused("build " + fifo + out, fifo + ": a FIFO, socket or device");
  ExpectRefused("build " + (dir_ / "folder.bag") + out, "folder.bag: an empty folder");
  ExpectRefused("info " + empty, empty + ": an empty file (0 bytes)");
  EXPECT_FALSE(fs::exists(dir_ / "out"));
}

TEST_F(HostileRound4Test, TopicsGivenWronglyAreRefused) {
  const std::string build = "build " + BaseSequence() + " -o " + (dir_ / "out");
  ExpectRefused(build + " --topic color=", "no topic name after '='");
  ExpectRefused(build + " --topic color=/a --topic color=/b", "--topic color= given twice");
  ExpectRefused(build + " --topic depth=/camera/depth", "a TUM-layout folder has no topics");
}

// YAML the user wrote wrongly (a --config, a camera.yaml, a bag's metadata.yaml): the line and
// the fix, never yaml-cpp's own words.
TEST_F(HostileRound4Test, BrokenYamlIsSaidWithItsLineAndTheFix) {
  struct Case {
    const char* text;
    const char* expected;
  };
  const Case cases[] = {
      {"mapping:\n\tvoxel_size: 0.01\n", ":2: not valid YAML: a tab in the indentation"},
      {"mapping: {voxel_size: 0.01\n",
       "not valid YAML: a map ('{ ... }' or indented keys) is not "
       "closed"},
      {"run:\n  detector: [none\n", "not valid YAML: a list ('[ ... ]') is not closed"},
      {"mapping:\n  voxel_size: 0.01\n   extra: 2\n", ":3: not valid YAML: a ':' where no value"},
      {"run:\n  detector: \"no\\qne\"\n", "not valid YAML: a backslash escape"},
      {"mapping:\n  voxel_size: [ {a: 1} ]\n",
       "key 'mapping.voxel_size' must hold a value or a "
       "list of values"},
  };
  const std::string config = dir_ / "config.yaml";
  for (const Case& c : cases) {
    std::ofstream(config) << c.text;
    ExpectRefused("build " + BaseSequence() + " -o " + (dir_ / "out") + " --config " + config,
                  c.expected);
  }
  const std::string camera = dir_ / "seq";
  fs::copy(BaseSequence(), camera, fs::copy_options::recursive);
  std::ofstream(camera + "/camera.yaml") << "width: 640\nheight: [480\n";
  ExpectRefused("build " + camera + " -o " + (dir_ / "out"),
                "camera.yaml:3: not valid YAML: a list ('[ ... ]') is not closed");
  fs::create_directories(dir_ / "bag");
  std::ofstream(dir_ / "bag/metadata.yaml") << "rosbag2_bagfile_information: {version: 5\n";
  ExpectRefused(
      "build " + (dir_ / "bag") + " -o " + (dir_ / "out"),
      "metadata.yaml:2: not valid YAML: a map ('{ ... }' or indented keys) is not closed");
  EXPECT_FALSE(fs::exists(dir_ / "out/map.ply"));
}

TEST_F(HostileRound4Test, MergeRefusesAFifoAndTheSameFolderTwice) {
  const std::string a = dir_ / "a", b = dir_ / "b";
  fs::create_directories(a);
  fs::create_directories(b);
  ASSERT_EQ(::mkfifo((a + "/session.bin").c_str(), 0600), 0);
  ExpectRefused("merge " + a + " " + b + " -o " + (dir_ / "m"),
                a + "/session.bin: the session record is not a regular file");
  fs::remove(a + "/session.bin");
  fs::create_directories(a + "/session.bin");
  ExpectRefused("merge " + a + " " + b + " -o " + (dir_ / "m"),
                a + "/session.bin: the session record is a folder");
  fs::create_directory_symlink(a, dir_ / "link");
  ExpectRefused("merge " + a + " " + (dir_ / "link") + " -o " + (dir_ / "m"),
                "the same folder as " + a);
  ExpectRefused("merge " + a + " " + a + "/ -o " + (dir_ / "m"), "the same folder as " + a);
}

// Two tracked sessions of one synthetic room merged into a folder holding the user's own map.ply:
// the merge warns, as the build does, and keeps the user's file beside.
TEST_F(HostileRound4Test, MergeWarnsOfTheUsersFilesItSetsAside) {
  std::string output;
  const std::string room = dir_ / "room";
  ASSERT_EQ(testing::RunStillmap("synth " + room + " --scenario static --frames 40", &output), 0)
      << output;
  for (const char* name : {"s1", "s2"}) {
    ASSERT_EQ(testing::RunStillmap(
                  "build " + room + " -o " + (dir_ / name) + " --quiet --detector none", &output),
              0)
        << output;
  }
  const std::string merged = dir_ / "merged";
  fs::create_directories(merged);
  std::ofstream(merged + "/map.ply") << "the user's own cloud";
  ASSERT_EQ(testing::RunStillmap("merge " + (dir_ / "s1") + " " + (dir_ / "s2") + " -o " + merged,
                                 &output),
            0)
      << output;
  EXPECT_NE(output.find(merged + "/map.ply was not written by stillmap; it is kept as " + merged +
                        "/map.ply.before-stillmap"),
            std::string::npos)
      << output;
  std::ifstream kept(merged + "/map.ply.before-stillmap");
  std::string text;
  std::getline(kept, text);
  EXPECT_EQ(text, "the user's own cloud");
}

}  // namespace
}  // namespace stillmap
