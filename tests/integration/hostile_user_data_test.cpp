// Hostile input, round 3: generated cases for what a user's files and settings must survive, each
// with its own expectation besides the corpus contract (exit 0, 1 or 2; no library text):
//   - YAML the readers must refuse: aliases into themselves, keys given twice, a second document,
//     nesting thousands deep (configuration, camera and grid files);
//   - files in output folders that no run wrote: never deleted or overwritten (kept aside,
//     renamed, with a warning), inside renders/ and synth folders too; the lock never followed
//     through a link; an interrupted swap completed by the next command; a stray folder of an
//     earlier version never moved over a newer file; view and eval never overwrite a non-image;
//   - input that used to pass in silence: class names that do not fit the model, swapped or
//     damaged models, a near-empty map, an implausible depth scale, a frozen colour stream, an
//     output folder that is the sequence through a bind mount, a vertical grid.floor, seeds
//     that wrap;
//   - messages: a huge PLY header, NUL and binary bytes in lists, CMYK JPEGs, broken PNG CRCs,
//     a plot into a missing folder, the OctoMap-off warning's key, an empty ground truth.
// Parameters (names, keys, depths, factors, bytes) come from the corpus' seeded generator
// (STILLMAP_HOSTILE_SEED); STILLMAP_HOSTILE_ROUND3 (default 2) sets the instances per case.
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
namespace {

namespace fs = std::filesystem;
using testing::ReadText;
using testing::RunCommand;
using testing::RunStillmap;
using testing::TempDir;
using testing::WriteText;

const size_t kInstances = EnvCount("STILLMAP_HOSTILE_ROUND3", 2);

// One case's folders: a copy of the base sequence and an output folder beside it.
// The base sequence at full size (640x480), for the cases that track the camera: the corpus' small
// base is too small for ORB features.
const std::string& TrackedBase() {
  static TempDir dir;
  static const std::string path = [] {
    std::string output;
    const std::string sequence = dir / "base";
    if (RunStillmap("synth " + sequence + " --scenario walking_xyz --frames 12 --seed 3",
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
    fs::copy(tracked ? TrackedBase() : BaseSequence(), sequence, fs::copy_options::recursive);
  }

  // Runs `arguments` through the binary under the corpus' limits and checks the contract.
  int Run(const std::string& arguments, std::string* output) const {
    const int status = RunStillmap(arguments, output, HostilePrefix());
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

  TempDir dir;
  const std::string sequence = dir / "seq";
  const std::string out = dir / "out";
};

std::string RandomName(Generator& g, const std::string& extension) {
  std::string name;
  for (size_t i = 0, n = 3 + g.Below(8); i < n; ++i) name += static_cast<char>('a' + g.Below(26));
  return name + extension;
}

std::string RandomBytes(Generator& g, size_t size) {
  std::string bytes(size, '\0');
  for (char& byte : bytes) byte = static_cast<char>(g.Below(256));
  return bytes;
}

// The files of `folder`, sorted (directory order differs between file systems; the generator's
// picks must not).
std::vector<std::string> FilesIn(const std::string& folder) {
  std::vector<std::string> paths;
  for (const fs::directory_entry& e : fs::directory_iterator(folder)) {
    paths.push_back(e.path().string());
  }
  std::sort(paths.begin(), paths.end());
  return paths;
}

const std::vector<std::string>& ConfigSections() {
  static const std::vector<std::string> sections = [] {
    std::set<std::string> unique;
    for (const ConfigKeyInfo& key : ListConfigKeys())
      unique.insert(key.name.substr(0, key.name.find('.')));
    return std::vector<std::string>(unique.begin(), unique.end());
  }();
  return sections;
}

// ---- YAML the readers refuse --------------------------------------------------------------

TEST(HostileUserDataTest, YamlThatRefersToItselfRepeatsOrNestsIsRefused) {
  Generator g(31);
  for (size_t i = 0; i < kInstances * 3; ++i) {
    Case c;
    const std::string anchor = RandomName(g, "");
    const std::string section = g.Pick(ConfigSections());
    const std::string key = g.Pick(ListConfigKeys()).name;
    const size_t depth = 40 + g.Below(5000);
    const size_t kind = g.Below(6);
    std::string yaml, expected;
    if (kind == 0) {
      yaml = section + ": &" + anchor + "\n  x: 1\n  inner: *" + anchor + "\n";
      expected = "alias";
    } else if (kind == 1) {
      yaml = section + ": &" + anchor + " {a: 1, more: *" + anchor + "}\n";
      expected = "alias";
    } else if (kind == 2) {
      const std::string name = key.substr(key.find('.') + 1);
      yaml = key.substr(0, key.find('.')) + ":\n  " + name + ": 1\n  " + name + ": 2\n";
      expected = "given twice";
    } else if (kind == 3) {
      yaml = "run:\n  threads: 1\n---\nrun:\n  threads: 2\n";
      expected = "documents";
    } else if (kind == 4) {
      yaml = std::string(depth, '[') + std::string(depth, ']') + "\n";
      expected = "nests";
    } else {
      for (size_t level = 0; level < 40 + depth % 60; ++level) {
        yaml += std::string(level, ' ') + "k" + std::to_string(level) + ":\n";
      }
      yaml += std::string(100 + depth % 60, ' ') + "v: 1\n";
      expected = "nests";
    }
    const bool camera = g.Below(3) == 0;
    const std::string file = camera ? c.sequence + "/camera.yaml" : c.dir / "c.yaml";
    if (camera) {
      yaml = kind == 2   ? ReadText(file) + "fx: 500\n"
             : kind == 3 ? ReadText(file) + "---\nfx: 1\n"
                         : yaml;
    }
    WriteText(file, yaml);
    std::string output;
    const int status = c.Build(camera ? "" : "--config " + file, &output);
    const std::string why = "case " + std::to_string(i) + " kind " + std::to_string(kind) +
                            (camera ? " (camera.yaml)" : " (--config)") + ":\n" +
                            yaml.substr(0, 300);
    EXPECT_EQ(status, 2) << why << "\n" << output;
    if (!camera || kind == 2 || kind == 3) {
      EXPECT_NE(output.find(camera && kind == 2 ? "given twice" : expected), std::string::npos)
          << why << "\n"
          << output;
    }
    EXPECT_NE(output.find(file), std::string::npos) << why << "\n" << output;
    EXPECT_FALSE(fs::exists(c.out + "/map.ply")) << why;
  }
}

// ---- files no run wrote ---------------------------------------------------------------------

// User files inside renders/, and files with an output's name in a folder no run used (the
// hand-written --config OUT/config.yaml among them): kept, renamed when in the way, and named.
TEST(HostileUserDataTest, FilesNoRunWroteAreNeverLost) {
  Generator g(32);
  const std::vector<std::string> names = {"report.html", "trajectory.txt", "keyframes.txt",
                                          "map.ply",     "config.yaml",    "renders/grid_top.png"};
  for (size_t i = 0; i < kInstances * 2; ++i) {
    Case c;
    std::string output;
    std::map<std::string, std::string> users;  // name -> content
    const bool earlier = g.Below(2) == 0;
    if (earlier) {
      ASSERT_EQ(c.Build("", &output), 0) << output;
    }
    users["renders/" + RandomName(g, ".png")] = RandomBytes(g, 100 + g.Below(1000));
    users["renders/" + RandomName(g, "") + "/" + RandomName(g, ".txt")] = RandomBytes(g, 50);
    std::set<std::string> in_the_way;
    if (!earlier) {
      for (size_t k = 0, n = 1 + g.Below(3); k < n; ++k) in_the_way.insert(g.Pick(names));
      for (const std::string& name : in_the_way) users[name] = RandomBytes(g, 10 + g.Below(100));
    }
    const bool own_config = !earlier && in_the_way.count("config.yaml") > 0;
    if (own_config) users["config.yaml"] = "mapping:\n  voxel_leaf_size: 0.03\n";
    for (const auto& [name, content] : users) {
      fs::create_directories(fs::path(c.out + "/" + name).parent_path());
      WriteText(c.out + "/" + name, content);
    }
    const bool refused = g.Below(4) == 0;  // a rerun refused for a bad option first
    if (refused) {
      EXPECT_EQ(c.Build("--set no.such_key=1", &output), 2) << output;
    }
    const int status = c.Build(own_config ? "--config " + c.out + "/config.yaml" : "", &output);
    ASSERT_EQ(status, 0) << output;
    for (const auto& [name, content] : users) {
      const std::string kept = in_the_way.count(name) > 0 ? name + ".before-stillmap" : name;
      EXPECT_EQ(ReadText(c.out + "/" + kept), content) << name << " lost\n" << output;
      if (in_the_way.count(name) > 0) {
        EXPECT_NE(output.find(c.out + "/" + name + " was not written by stillmap"),
                  std::string::npos)
            << output;
      }
    }
    if (own_config) {
      EXPECT_NE(ReadText(c.out + "/config.yaml").find("voxel_leaf_size: 0.03"), std::string::npos)
          << "--config OUT/config.yaml was not read before the run wrote its own";
    }
    // The next run's files are the tool's own: replaced, nothing new kept aside.
    ASSERT_EQ(c.Build("", &output), 0) << output;
    EXPECT_EQ(output.find("was not written by stillmap"), std::string::npos) << output;
  }
}

// Runs a build of `c` into its output folder with every rename slowed to 0.2 s and kills it
// `delay_s` after its swap's journal appears. False when the build ended first.
bool KillInsideTheSwap(const Case& c, double delay_s) {
  const std::string journal = c.out + "/.stillmap-build-swap";
  const pid_t pid = ::fork();
  if (pid == 0) {
    ::setenv("LD_PRELOAD", STILLMAP_RENAME_DELAY, 1);
    ::setenv("STILLMAP_TEST_RENAME_DELAY_US", "200000", 1);
    ::setenv("ASAN_OPTIONS", "verify_asan_link_order=0:detect_leaks=0", 1);
    ::execl(STILLMAP_BINARY, STILLMAP_BINARY, "build", c.sequence.c_str(), "-o", c.out.c_str(),
            "--quiet", "--poses", "groundtruth", static_cast<char*>(nullptr));
    ::_exit(127);
  }
  bool began = false;
  int status = 0;
  for (int waited_ms = 0; waited_ms < 1000 * kTimeLimitS; waited_ms += 5) {
    if (fs::exists(journal)) {
      began = true;
      ::usleep(static_cast<useconds_t>(delay_s * 1e6));
      break;
    }
    if (::waitpid(pid, &status, WNOHANG) == pid) return false;
    ::usleep(5000);
  }
  ::kill(pid, SIGKILL);
  ::waitpid(pid, &status, 0);
  return began;
}

// A lock that is a link is refused; a stray folder of an earlier version's swap never moves over
// a newer file; a build killed while swapping is completed by view or by the next build, even
// one refused for a bad option.
TEST(HostileUserDataTest, LocksLeftoversAndKilledSwapsKeepTheFolderWhole) {
  Generator g(33);
  for (size_t i = 0; i < kInstances * 2; ++i) {
    Case c;
    std::string output;
    ASSERT_EQ(c.Build("", &output), 0) << output;
    const size_t kind = g.Below(3);
    if (kind == 0) {
      const std::string precious = c.dir / RandomName(g, ".txt");
      const std::string content = RandomBytes(g, 20);
      WriteText(precious, content);
      fs::remove(c.out + "/.stillmap.lock");
      fs::create_symlink(precious, c.out + "/.stillmap.lock");
      EXPECT_EQ(c.Build("", &output), 2) << output;
      EXPECT_NE(output.find("symbolic link"), std::string::npos) << output;
      EXPECT_EQ(ReadText(precious), content);
    } else if (kind == 1) {
      const std::string name = RandomName(g, ".txt");
      fs::create_directories(c.out + "/.stillmap-previous");
      WriteText(c.out + "/.stillmap-previous/" + name, "stale");
      WriteText(c.out + "/" + name, "newer");
      EXPECT_EQ(c.Run("view " + c.out + " --png", &output), 0) << output;
      EXPECT_EQ(c.Build("", &output), 0) << output;
      EXPECT_EQ(ReadText(c.out + "/" + name), "newer");
    } else {
      // Killed inside the swap of a rerun: renames slowed down by the test's shim, the kill a
      // random time after the swap's journal appears.
      const double delay_s = 0.05 * static_cast<double>(g.Below(60));
      EXPECT_TRUE(KillInsideTheSwap(c, delay_s)) << "the swap never began";
      if (g.Below(2) == 0) {
        EXPECT_EQ(c.Build("--threads 0", &output), 2) << output;
      }
      EXPECT_EQ(c.Run("view " + c.out + " --png", &output), 0)
          << "killed after " << delay_s << " s\n"
          << output;
      for (const char* name : {"map.ply", "map.pcd", "map.bt", "trajectory.txt", "report.json"}) {
        EXPECT_TRUE(fs::is_regular_file(c.out + "/" + name))
            << name << ", killed after " << delay_s << " s";
      }
      EXPECT_TRUE(nlohmann::json::accept(ReadText(c.out + "/report.json")));
    }
  }
}

// view --screenshot and eval --plot refuse names that are not images, and never replace a file
// that is not one; a plot into a missing folder names the folder.
TEST(HostileUserDataTest, ImagesAreNeverWrittenOverOtherFiles) {
  Generator g(34);
  for (size_t i = 0; i < kInstances * 2; ++i) {
    Case c;
    std::string output;
    ASSERT_EQ(c.Build("", &output), 0) << output;
    const std::string extension = g.Pick(std::vector<std::string>{".txt", ".png", ".PNG", ""});
    const std::string target = c.dir / RandomName(g, extension);
    const std::string content = RandomBytes(g, 30);
    WriteText(target, content);
    const std::string groundtruth = c.sequence + "/groundtruth.txt";
    EXPECT_EQ(c.Run("view " + c.out + " --screenshot " + target, &output), 2) << output;
    EXPECT_EQ(c.Run("eval " + groundtruth + " " + groundtruth + " --plot " + target, &output), 2)
        << output;
    EXPECT_EQ(ReadText(target), content);
    const std::string missing = c.dir / (RandomName(g, "") + "/" + RandomName(g, "") + "/p.png");
    EXPECT_EQ(c.Run("eval " + groundtruth + " " + groundtruth + " --plot " + missing, &output), 2);
    EXPECT_EQ(output.find(".tmp"), std::string::npos) << output;
    EXPECT_NE(output.find("does not exist"), std::string::npos) << output;
  }
}

// synth reruns replace exactly what the last synth run wrote; a folder with only a synth.json
// (no record of a run) is not taken for one.
TEST(HostileUserDataTest, SynthRerunsKeepTheUsersFiles) {
  Generator g(35);
  for (size_t i = 0; i < kInstances; ++i) {
    TempDir dir;
    const std::string s = dir / "s";
    std::string output;
    const std::string synth = "synth " + s + " --scenario walking_xyz --threads 1 --frames ";
    ASSERT_EQ(RunStillmap(synth + std::to_string(3 + g.Below(3)), &output, HostilePrefix()), 0)
        << output;
    std::map<std::string, std::string> users;
    for (const char* folder : {"rgb", "masks", "depth"}) {
      users[std::string(folder) + "/" + RandomName(g, ".png")] = RandomBytes(g, 64);
    }
    for (const auto& [name, content] : users) WriteText(s + "/" + name, content);
    ASSERT_EQ(RunStillmap(synth + std::to_string(2 + g.Below(3)), &output, HostilePrefix()), 0)
        << output;
    for (const auto& [name, content] : users) EXPECT_EQ(ReadText(s + "/" + name), content) << name;
    const std::string fake = dir / "fake";
    fs::create_directories(fake + "/rgb");
    WriteText(fake + "/synth.json", "{}");
    WriteText(fake + "/rgb/mine.png", "the user's");
    EXPECT_EQ(
        RunStillmap("synth " + fake + " --scenario static --frames 2", &output, HostilePrefix()), 2)
        << output;
    EXPECT_EQ(ReadText(fake + "/rgb/mine.png"), "the user's");
  }
}

// ---- input that used to pass in silence -----------------------------------------------------

// Names files that do not fit the model, and models swapped, cut short, damaged or not models at
// all: exit 2 at load, naming the file, before anything is written.
TEST(HostileUserDataTest, ModelsAndNamesThatDoNotFitAreNamedAtLoad) {
  const std::optional<std::string> yolox = testing::SharedModels("yolox_nano");
  const std::optional<std::string> deeplab = testing::SharedModels("deeplabv3_mnv2_voc");
  const std::optional<std::string> fastest = testing::SharedModels("yolo_fastest_1.1");
  if (!yolox || !deeplab || !fastest) GTEST_SKIP() << "no detector models in ../shared/models";
  // Per detector: its folder, names file and model file (Yolo-Fastest's weights).
  struct Model {
    std::string detector, folder, names, file;
  };
  const std::vector<Model> kinds = {
      {"yolox", "yolox_nano", "coco.names", "yolox_nano.onnx"},
      {"deeplab", "deeplabv3_mnv2_voc", "voc.names", "deeplab_v3_mnv2_voc_opencv46.onnx"},
      {"yolo-fastest", "yolo_fastest_1.1", "coco.names", "yolo-fastest-1.1.weights"}};
  Generator g(36);
  for (size_t i = 0; i < kInstances * 3; ++i) {
    Case c;
    const std::string models = c.dir / "models";
    fs::create_directories(models);
    for (const Model& each : kinds) {
      fs::copy(*yolox + "/" + each.folder, models + "/" + each.folder, fs::copy_options::recursive);
    }
    const Model& chosen = kinds[g.Below(kinds.size())];
    const Model& another = kinds[chosen.detector == "yolox" ? 1 : 0];
    const std::string folder = models + "/" + chosen.folder + "/";
    const std::string names = folder + chosen.names;
    const std::string model = folder + chosen.file;
    const std::string other = models + "/" + another.folder + "/" + another.file;
    const size_t kind = g.Below(7);
    std::string wrong = names;
    if (kind == 0) {
      WriteText(names, "");
    } else if (kind == 1) {
      std::vector<std::string> lines = Lines(ReadText(names));
      lines.resize(g.Below(lines.size()));
      WriteText(names, Join(lines));
    } else if (kind == 2) {
      WriteText(names, RandomBytes(g, 200));
    } else if (kind == 3) {
      fs::copy_file(other, model, fs::copy_options::overwrite_existing);
      wrong = model;
    } else if (kind == 4) {
      fs::resize_file(model, fs::file_size(model) * g.Below(100) / 100);
      wrong = model;
    } else if (kind == 5) {
      std::string bytes = ReadText(model);
      for (size_t k = 0; k < 64; ++k) bytes[g.Below(bytes.size() / 8)] ^= 0x5a;
      WriteText(model, bytes);
      wrong = model;
    } else {
      WriteText(model, "not a model\n");
      wrong = model;
    }
    std::string output;
    const int status = c.Build("--detector " + chosen.detector + " --models " + models, &output);
    EXPECT_EQ(status, 2) << "kind " << kind << "\n" << output;
    EXPECT_NE(output.find(wrong), std::string::npos) << "kind " << kind << "\n" << output;
    EXPECT_FALSE(fs::exists(c.out + "/map.ply"));
  }
}

// A near-empty map fails; a depth scale far off and a frozen colour stream are warned of (and
// the base sequence itself raises neither warning).
TEST(HostileUserDataTest, ImplausibleRecordingsAreNamed) {
  Generator g(37);
  for (size_t i = 0; i < kInstances * 2; ++i) {
    Case c;
    std::string output;
    const size_t kind = g.Below(3);
    const std::vector<std::string> depths = FilesIn(c.sequence + "/depth");
    if (kind == 0) {
      for (const std::string& path : depths) {
        cv::Mat depth = cv::imread(path, cv::IMREAD_UNCHANGED);
        cv::Mat kept = cv::Mat::zeros(depth.size(), depth.type());
        for (size_t k = 0, n = 1 + g.Below(3); k < n; ++k) {
          const int r = static_cast<int>(g.Below(depth.rows)),
                    col = static_cast<int>(g.Below(depth.cols));
          kept.at<std::uint16_t>(r, col) = 10000;
        }
        cv::imwrite(path, kept);
      }
      EXPECT_EQ(c.Build("", &output), 1) << output;
      EXPECT_NE(output.find("empty"), std::string::npos) << output;
    } else if (kind == 1) {
      const double factor = g.Pick(std::vector<double>{5.0, 0.2, 8.0, 0.125});
      std::string camera = ReadText(c.sequence + "/camera.yaml");
      camera = std::regex_replace(camera, std::regex("depth_factor: .*"),
                                  "depth_factor: " + std::to_string(5000.0 * factor));
      WriteText(c.sequence + "/camera.yaml", camera);
      const int status = c.Build("", &output);
      EXPECT_TRUE(status == 0 || status == 1) << output;
      EXPECT_NE(output.find("depth scale"), std::string::npos) << factor << "\n" << output;
    } else {
      const cv::Mat noise(120, 160, CV_8UC3);
      cv::randu(noise, 0, 255);
      for (const std::string& path : FilesIn(c.sequence + "/rgb")) cv::imwrite(path, noise);
      EXPECT_EQ(c.Build("", &output), 0) << output;
      EXPECT_NE(output.find("frozen"), std::string::npos) << output;
    }
  }
  Case c(true);
  std::string output;
  ASSERT_EQ(c.Run("build " + c.sequence + " -o " + c.out + " --quiet", &output), 0) << output;
  EXPECT_EQ(output.find("frozen"), std::string::npos) << output;
  EXPECT_EQ(output.find("depth scale"), std::string::npos) << output;
}

// An output folder that is the sequence (or inside it) through a bind mount is refused.
TEST(HostileUserDataTest, AnOutputFolderMountedOverTheSequenceIsRefused) {
  Generator g(38);
  for (size_t i = 0; i < kInstances; ++i) {
    Case c;
    const std::string mount = c.dir / RandomName(g, "");
    fs::create_directories(mount);
    if (::mount(c.sequence.c_str(), mount.c_str(), nullptr, MS_BIND, nullptr) != 0) {
      GTEST_SKIP() << "bind mounts need privileges this machine does not give";
    }
    const std::string out = g.Below(2) == 0 ? mount : mount + "/" + RandomName(g, "");
    const size_t before = std::distance(fs::directory_iterator(c.sequence), {});
    std::string output;
    const int status = c.Run("build " + c.sequence + " -o " + out + " --quiet", &output);
    ::umount(mount.c_str());
    EXPECT_EQ(status, 2) << output;
    EXPECT_NE(output.find("sequence folder"), std::string::npos) << output;
    EXPECT_EQ(std::distance(fs::directory_iterator(c.sequence), {}), before);
  }
}

// Values that wrap or make no sense: a vertical grid.floor, negative or overflowing seeds.
TEST(HostileUserDataTest, ValuesThatWrapOrMakeNoSenseAreRefused) {
  Generator g(39);
  for (size_t i = 0; i < kInstances * 2; ++i) {
    Case c;
    std::string output;
    const double angle = static_cast<double>(g.Below(360)) * M_PI / 180.0;
    const std::string floor = std::to_string(std::cos(angle)) + " 0 " +
                              std::to_string(std::sin(angle)) + " " +
                              std::to_string(static_cast<double>(g.Below(5)) - 2.0);
    EXPECT_EQ(c.Build("--set 'grid.floor=" + floor + "'", &output), 2) << floor << "\n" << output;
    EXPECT_NE(output.find("not a floor"), std::string::npos) << output;
    const std::string seed = g.Pick(
        std::vector<std::string>{"-" + std::to_string(1 + g.Below(1000)), "18446744073709551616",
                                 "99999999999999999999999", "12x", "1e3", "-0"});
    EXPECT_EQ(
        c.Run("synth " + (c.dir / "s") + " --scenario static --frames 2 --seed " + seed, &output),
        2)
        << seed << "\n"
        << output;
    EXPECT_FALSE(fs::exists(c.dir / "s"));
  }
}

// ---- messages ------------------------------------------------------------------------------

TEST(HostileUserDataTest, DamagedFilesGetOurSentence) {
  Generator g(40);
  for (size_t i = 0; i < kInstances * 3; ++i) {
    const size_t kind = g.Below(5);
    const Case c(kind == 4);
    std::string output;
    if (kind == 0) {  // a PLY header declaring more vertices than its bytes hold
      ASSERT_EQ(c.Build("", &output), 0) << output;
      const unsigned long long vertices = 1000000000ULL * (1 + g.Below(1000000));
      WriteText(c.out + "/map.ply", "ply\nformat binary_little_endian 1.0\nelement vertex " +
                                        std::to_string(vertices) +
                                        "\nproperty float x\nproperty float y\nproperty float "
                                        "z\nend_header\n" +
                                        RandomBytes(g, 64));
      EXPECT_EQ(c.Run("view " + c.out + " --png", &output), 2) << output;
      EXPECT_NE(output.find("declares"), std::string::npos) << output;
    } else if (kind == 1) {  // NUL or binary bytes in rgb.txt
      std::string list = ReadText(c.sequence + "/rgb.txt");
      const size_t at = list.find("rgb/") + 4;
      if (g.Below(2) == 0) {
        list.insert(at, 1, '\0');
      } else {
        list = RandomBytes(g, 400);
      }
      WriteText(c.sequence + "/rgb.txt", list);
      EXPECT_EQ(c.Build("", &output), 2) << output;
      for (const char byte : output) {
        const auto u = static_cast<unsigned char>(byte);
        EXPECT_TRUE(u >= 0x20 || byte == '\n') << "raw byte " << static_cast<int>(u);
        if (u < 0x20 && byte != '\n') break;
      }
    } else if (kind == 2) {  // CR-only line endings: read as lines
      for (const char* list : {"rgb.txt", "depth.txt", "groundtruth.txt"}) {
        std::string text = ReadText(c.sequence + "/" + list);
        std::replace(text.begin(), text.end(), '\n', '\r');
        WriteText(c.sequence + "/" + list, text);
      }
      EXPECT_EQ(c.Build("", &output), 0) << output;
    } else if (kind == 3) {  // a broken CRC in a PNG: our sentence, not libpng's
      const std::string folder = g.Below(2) == 0 ? "/rgb" : "/depth";
      const std::vector<std::string> paths = FilesIn(c.sequence + folder);
      const std::string path = paths[g.Below(paths.size())];
      std::string bytes = ReadText(path);
      const size_t idat = bytes.find("IDAT");
      ASSERT_NE(idat, std::string::npos);
      const size_t length = (static_cast<unsigned char>(bytes[idat - 2]) << 8) +
                            static_cast<unsigned char>(bytes[idat - 1]);
      bytes[idat + 4 + length + g.Below(4)] ^= static_cast<char>(1 + g.Below(255));
      WriteText(path, bytes);
      EXPECT_EQ(c.Build("", &output), 2) << output;
      EXPECT_NE(output.find(path), std::string::npos) << output;
    } else {  // an empty ground truth: a tracked build maps without ATE, --poses groundtruth stops
      WriteText(c.sequence + "/groundtruth.txt", g.Below(2) == 0 ? "" : "# no poses\n\n");
      EXPECT_EQ(c.Run("build " + c.sequence + " -o " + c.out + " --quiet", &output), 0) << output;
      EXPECT_NE(output.find("holds no poses"), std::string::npos) << output;
      EXPECT_EQ(c.Build("", &output), 2) << output;
    }
  }
}

// Writes `bgr` as an Adobe-style CMYK JPEG (inverted channels, APP14 marker) through libjpeg.
void WriteCmykJpeg(const std::string& path, const cv::Mat& bgr) {
  jpeg_compress_struct info{};
  jpeg_error_mgr error{};
  info.err = jpeg_std_error(&error);
  jpeg_create_compress(&info);
  FILE* file = std::fopen(path.c_str(), "wb");
  ASSERT_NE(file, nullptr);
  jpeg_stdio_dest(&info, file);
  info.image_width = static_cast<JDIMENSION>(bgr.cols);
  info.image_height = static_cast<JDIMENSION>(bgr.rows);
  info.input_components = 4;
  info.in_color_space = JCS_CMYK;
  jpeg_set_defaults(&info);
  jpeg_set_quality(&info, 95, TRUE);
  jpeg_start_compress(&info, TRUE);
  std::vector<unsigned char> row(static_cast<size_t>(bgr.cols) * 4);
  for (int r = 0; r < bgr.rows; ++r) {
    for (int col = 0; col < bgr.cols; ++col) {
      const cv::Vec3b& p = bgr.at<cv::Vec3b>(r, col);
      // Inverted CMYK with no black ink: C' = R, M' = G, Y' = B, K' = 255.
      row[col * 4 + 0] = p[2], row[col * 4 + 1] = p[1], row[col * 4 + 2] = p[0],
                    row[col * 4 + 3] = 255;
    }
    JSAMPROW pointer = row.data();
    jpeg_write_scanlines(&info, &pointer, 1);
  }
  jpeg_finish_compress(&info);
  jpeg_destroy_compress(&info);
  std::fclose(file);
}

TEST(HostileUserDataTest, CmykJpegsAreDecodedAndTheOctomapWarningNamesARealKey) {
  Generator g(41);
  for (size_t i = 0; i < kInstances; ++i) {
    Case c;
    std::string output;
    std::vector<std::string> list = Lines(ReadText(c.sequence + "/rgb.txt"));
    for (std::string& line : list) {
      if (line.empty() || line[0] == '#') continue;
      const std::string path = c.sequence + "/" + line.substr(line.find(' ') + 1);
      const std::string jpeg = path.substr(0, path.size() - 4) + "_cmyk.jpg";
      WriteCmykJpeg(jpeg, cv::imread(path, cv::IMREAD_COLOR));
      line = line.substr(0, line.find(' ') + 1) + jpeg.substr(c.sequence.size() + 1);
    }
    WriteText(c.sequence + "/rgb.txt", Join(list));
    const bool octomap_off = g.Below(2) == 0;
    ASSERT_EQ(c.Build(octomap_off ? "--set octomap.enabled=false" : "", &output), 0) << output;
    // Every configuration key a warning names exists.
    std::set<std::string> known;
    for (const ConfigKeyInfo& key : ListConfigKeys()) known.insert(key.name);
    const std::regex key_pattern("\\(([a-z_]+\\.[a-z_.]+)=");
    for (std::sregex_iterator it(output.begin(), output.end(), key_pattern), end; it != end; ++it) {
      EXPECT_EQ(known.count((*it)[1]), 1u) << (*it)[1] << " is no key\n" << output;
    }
    if (octomap_off) {
      EXPECT_NE(output.find("(octomap.enabled="), std::string::npos) << output;
    }
  }
}

}  // namespace
}  // namespace stillmap
