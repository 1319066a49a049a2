// Hostile input, derived automatically: corrupted variants of a small real-looking sequence (list
// files truncated, fields swapped, numbers replaced by NaN/inf/huge/negative values, images
// truncated, zeroed, swapped, resized, corrupted; folders, FIFOs and link loops where files
// belong; extreme option values), each run through the real binary. For every variant:
//   - no signal and no hang (each run has a time limit), exit status 0, 1 or 2 only;
//   - on 1 or 2, one last line "stillmap: error: ..." / "stillmap: failed: ..." that is a sentence
//     of ours, not a library's internal message, and no output set that looks finished;
//   - on 0, the whole output set, with a report that parses and a cloud that is not empty.
// Variants come from a seeded generator: STILLMAP_HOSTILE_SEED (default 1) picks another set,
// STILLMAP_HOSTILE_VARIANTS (default 60 a family) changes how many; a failure prints the variant
// and how to rerun it. Under the sanitizer preset every run also has ASan and UBSan watching.
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <algorithm>
#include <filesystem>
#include <functional>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <random>
#include <sstream>

#include "hostile_corpus.h"
#include "stillmap/io/cloud_files.h"
#include "stillmap/pipeline/config.h"
#include "test_util.h"

namespace stillmap {
namespace {

namespace fs = std::filesystem;
using testing::ReadText;
using testing::RunStillmap;
using testing::TempDir;
using testing::WriteText;

// One variant: a description, what it does to its copy of the sequence (and output folder), and
// the command line after "stillmap".
struct Variant {
  std::string description;
  std::function<void(const std::string& sequence, const std::string& out)> mutate;
  std::string arguments;  // appended to "build SEQUENCE -o OUT --quiet ..."
};

// Hostile replacements for a number.
const std::vector<std::string>& HostileNumbers() {
  static const std::vector<std::string> kNumbers = {
      "nan", "inf",        "-inf",    "1e308", "-1e308",   "1e20", "-1e20", "0",          "-1",
      "-0",  "4294967297", "1e-320",  "0x10",  "12abc",    "",     ".5",    "1e6",        "-1e6",
      "1e4", "999999999",  "-0.0001", "NaN",   "Infinity", "1e+",  "--1",   "3.40282e+39"};
  return kNumbers;
}

// The files a sequence lists: "rgb" or "depth" images.
std::vector<std::string> ListedImages(const std::string& sequence, const std::string& list) {
  std::vector<std::string> paths;
  for (const std::string& line : Lines(ReadText(sequence + "/" + list + ".txt"))) {
    if (line.empty() || line[0] == '#') continue;
    paths.push_back(sequence + "/" + line.substr(line.find(' ') + 1));
  }
  return paths;
}

const std::vector<std::string> kListFiles = {"rgb.txt",   "depth.txt",   "groundtruth.txt",
                                             "masks.txt", "objects.txt", "camera.yaml"};

// Text files: truncated at a line or inside one, lines swapped, duplicated, emptied, fields
// swapped, garbage added, line endings changed.
Variant ListVariant(Generator& g) {
  const std::string file = g.Pick(kListFiles);
  const size_t kind = g.Below(9);
  const size_t line_pick = g.Below(1000), other_pick = g.Below(1000), byte_pick = g.Below(1000);
  static const std::vector<std::string> kNames = {"truncated at a line",
                                                  "truncated inside a line",
                                                  "two lines swapped",
                                                  "a line repeated",
                                                  "emptied",
                                                  "two fields of a line swapped",
                                                  "binary garbage line",
                                                  "CRLF line endings",
                                                  "a 1 MB line"};
  auto mutate = [=](const std::string& sequence, const std::string&) {
    const std::string path = sequence + "/" + file;
    std::vector<std::string> lines = Lines(ReadText(path));
    if (lines.empty()) return;
    const size_t a = line_pick % lines.size(), b = other_pick % lines.size();
    switch (kind) {
      case 0:
        lines.resize(a);
        break;
      case 1:
        lines[a] = lines[a].substr(0, byte_pick % (lines[a].size() + 1));
        lines.resize(a + 1);
        break;
      case 2:
        std::swap(lines[a], lines[b]);
        break;
      case 3:
        lines.insert(lines.begin() + static_cast<long>(a), lines[a]);
        break;
      case 4:
        lines.clear();
        break;
      case 5: {
        std::istringstream in(lines[a]);
        std::vector<std::string> fields;
        for (std::string field; in >> field;) fields.push_back(field);
        if (fields.size() >= 2) {
          std::swap(fields[byte_pick % fields.size()], fields[other_pick % fields.size()]);
          std::string joined;
          for (const std::string& field : fields) joined += field + " ";
          lines[a] = joined;
        }
        break;
      }
      case 6:
        lines.insert(lines.begin() + static_cast<long>(a),
                     std::string("\x01\xff\xfe\x00garbage", 12));
        break;
      case 7:
        for (std::string& line : lines) line += "\r";
        break;
      default:
        lines[a] += " " + std::string(1 << 20, '7');
        break;
    }
    WriteText(path, Join(lines));
  };
  return {file + ": " + kNames[kind], mutate, ""};
}

// A number of a list file replaced by a hostile one.
Variant NumberVariant(Generator& g) {
  const std::string file = g.Pick(kListFiles);
  const std::string number = g.Pick(HostileNumbers());
  const size_t line_pick = g.Below(1000), field_pick = g.Below(1000);
  auto mutate = [=](const std::string& sequence, const std::string&) {
    const std::string path = sequence + "/" + file;
    std::vector<std::string> lines = Lines(ReadText(path));
    std::vector<size_t> candidates;  // lines with a number
    for (size_t i = 0; i < lines.size(); ++i) {
      if (!lines[i].empty() && lines[i][0] != '#' &&
          lines[i].find_first_of("0123456789") != std::string::npos) {
        candidates.push_back(i);
      }
    }
    if (candidates.empty()) return;
    std::string& line = lines[candidates[line_pick % candidates.size()]];
    // The numbers of the line: maximal runs of [0-9.eE+-] that hold a digit.
    std::vector<std::pair<size_t, size_t>> spans;
    for (size_t i = 0; i < line.size();) {
      const size_t end = line.find_first_not_of("0123456789.eE+-", i);
      const size_t stop = end == std::string::npos ? line.size() : end;
      if (stop > i && line.substr(i, stop - i).find_first_of("0123456789") != std::string::npos) {
        spans.emplace_back(i, stop - i);
      }
      i = stop + 1;
    }
    if (spans.empty()) return;
    const auto [at, length] = spans[field_pick % spans.size()];
    line.replace(at, length, number);
    WriteText(path, Join(lines));
  };
  return {file + ": a number replaced by '" + number + "'", mutate, ""};
}

// Images: damaged bytes, wrong content, wrong size or format.
Variant ImageVariant(Generator& g) {
  const std::string list = g.Below(2) == 0 ? "rgb" : "depth";
  const size_t kind = g.Below(12);
  const size_t frame_pick = g.Below(1000), byte_pick = g.Below(1 << 30);
  const bool every_frame = g.Below(3) == 0;
  static const std::vector<std::string> kNames = {"truncated",
                                                  "bytes zeroed",
                                                  "pixels all zero",
                                                  "pixels all maximum",
                                                  "swapped with the other kind",
                                                  "resized",
                                                  "8-bit single channel",
                                                  "16-bit 3 channels",
                                                  "middle bytes corrupted",
                                                  "corrupt JPEG ending in FF D9",
                                                  "empty file",
                                                  "PNG header claiming 100000 x 100000"};
  auto mutate = [=](const std::string& sequence, const std::string&) {
    const std::vector<std::string> paths = ListedImages(sequence, list);
    const std::vector<std::string> others = ListedImages(sequence, list == "rgb" ? "depth" : "rgb");
    for (size_t k = 0; k < paths.size(); ++k) {
      if (!every_frame && k != frame_pick % paths.size()) continue;
      const std::string& path = paths[k];
      std::string bytes = ReadText(path);
      cv::Mat image = cv::imread(path, cv::IMREAD_UNCHANGED);
      switch (kind) {
        case 0:
          bytes.resize(byte_pick % bytes.size());
          WriteText(path, bytes);
          break;
        case 1:
          std::fill(bytes.begin(), bytes.end(), '\0');
          WriteText(path, bytes);
          break;
        case 2:
          image.setTo(0);
          cv::imwrite(path, image);
          break;
        case 3:
          image.setTo(cv::Scalar::all(image.depth() == CV_16U ? 65535 : 255));
          cv::imwrite(path, image);
          break;
        case 4:
          fs::copy_file(others[k % others.size()], path, fs::copy_options::overwrite_existing);
          break;
        case 5:
          cv::resize(image, image, cv::Size(), 1.5, 0.5);
          cv::imwrite(path, image);
          break;
        case 6:
          cv::imwrite(path, cv::Mat(image.size(), CV_8UC1, cv::Scalar(77)));
          break;
        case 7:
          cv::imwrite(path, cv::Mat(image.size(), CV_16UC3, cv::Scalar(1000, 2000, 3000)));
          break;
        case 8:
          for (size_t i = bytes.size() / 3; i < bytes.size() / 3 + 16 && i < bytes.size(); ++i)
            bytes[i] ^= 0x5a;
          WriteText(path, bytes);
          break;
        case 9: {
          std::vector<unsigned char> jpeg;
          cv::Mat color = image.channels() == 3
                              ? image
                              : cv::Mat(image.size(), CV_8UC3, cv::Scalar(90, 120, 200));
          cv::imencode(".jpg", color, jpeg);
          for (size_t i = jpeg.size() / 2; i < jpeg.size() / 2 + 40; ++i)
            jpeg[i] = static_cast<unsigned char>(i * 37);
          WriteText(path, std::string(jpeg.begin(), jpeg.end()));
          break;
        }
        case 10:
          WriteText(path, "");
          break;
        default:
          if (bytes.size() > 24) {
            const char huge[8] = {0, 1, static_cast<char>(0x86), static_cast<char>(0xa0),
                                  0, 1, static_cast<char>(0x86), static_cast<char>(0xa0)};
            bytes.replace(16, 8, huge, 8);
            WriteText(path, bytes);
          }
          break;
      }
    }
  };
  return {list + " image(s)" + (every_frame ? " (every frame)" : "") + ": " + kNames[kind], mutate,
          ""};
}

// Files that are not files: folders, FIFOs, link loops, dangling links; output folders in the way.
Variant FileSystemVariant(Generator& g) {
  const size_t kind = g.Below(8);
  const std::string file = g.Pick(std::vector<std::string>{
      "rgb.txt", "depth.txt", "groundtruth.txt", "camera.yaml", "masks.txt", "image"});
  const size_t frame_pick = g.Below(1000);
  static const std::vector<std::string> kNames = {"is a folder",
                                                  "is a FIFO",
                                                  "is a symbolic link loop",
                                                  "is a dangling symbolic link",
                                                  "output folder is a file",
                                                  "output folder holds a folder named map.ply",
                                                  "output folder is a symbolic link loop",
                                                  "output folder holds an earlier build"};
  auto mutate = [=](const std::string& sequence, const std::string& out) {
    std::string path = sequence + "/" + file;
    if (file == "image") {
      const std::vector<std::string> images =
          ListedImages(sequence, frame_pick % 2 ? "rgb" : "depth");
      path = images[frame_pick % images.size()];
    }
    switch (kind) {
      case 0:
        fs::remove(path);
        fs::create_directory(path);
        break;
      case 1:
        fs::remove(path);
        mkfifo(path.c_str(), 0644);
        break;
      case 2:
        fs::remove(path);
        fs::create_symlink(path, path);
        break;
      case 3:
        fs::remove(path);
        fs::create_symlink(path + ".nowhere", path);
        break;
      case 4:
        WriteText(out, "a file");
        break;
      case 5:
        fs::create_directories(out + "/map.ply");
        break;
      case 6:
        fs::create_symlink(out, out);
        break;
      default: {
        std::string output;
        RunStillmap("build " + sequence + " -o " + out + " --quiet --poses groundtruth", &output);
        // ... and then a damaging change to the sequence for the rerun.
        fs::resize_file(ListedImages(sequence, "depth").back(), 100);
        break;
      }
    }
  };
  return {(kind < 4 ? file + " " : std::string()) + kNames[kind], mutate, ""};
}

// Option values: a random key with a hostile value, or two at once.
Variant OptionVariant(Generator& g) {
  static const std::vector<ConfigKeyInfo> keys = ListConfigKeys();
  static const std::vector<std::string> kValues = {
      "nan", "inf",  "-inf", "1e308", "-1e308", "0",    "-1",     "4294967297", "1e20",
      "2e9", "true", "",     "x",     "0.5",    "1e-9", "100000", "9999999",    "1"};
  std::string arguments;
  const size_t count = 1 + g.Below(2);
  for (size_t i = 0; i < count; ++i) {
    const std::string& key = g.Pick(keys).name;
    if (key == "camera.preset" || key == "detector.levels") continue;  // strings, tested elsewhere
    arguments += " --set '" + key + "=" + g.Pick(kValues) + "'";
  }
  if (g.Below(4) == 0)
    arguments += " --threads " + g.Pick(std::vector<std::string>{"1", "3", "64"});
  return {"options:" + arguments, [](const std::string&, const std::string&) {}, arguments};
}

// What a finished output set holds in every configuration.
const std::vector<std::string> kAlwaysWritten = {"map.ply",       "map.pcd",     "trajectory.txt",
                                                 "keyframes.txt", "report.json", "report.html",
                                                 "config.yaml"};

class HostileInputTest : public ::testing::Test {
 protected:
  // Runs one variant in a fresh copy of the base sequence and checks the contract.
  void Check(size_t index, const Variant& variant, bool ground_truth_poses) {
    TempDir dir;
    const std::string sequence = dir / "seq", out = dir / "out";
    fs::copy(BaseSequence(), sequence, fs::copy_options::recursive);
    variant.mutate(sequence, out);
    std::error_code error;
    std::vector<std::string> earlier;  // outputs (or things in their way) there before the run
    for (const std::string& name : kAlwaysWritten) {
      if (fs::exists(fs::symlink_status(out + "/" + name, error))) earlier.push_back(name);
    }
    const std::string earlier_report = fs::is_regular_file(out + "/report.json", error)
                                           ? ReadText(out + "/report.json")
                                           : std::string();
    const std::string arguments = "build " + sequence + " -o " + out + " --quiet" +
                                  (ground_truth_poses ? " --poses groundtruth" : "") +
                                  variant.arguments;
    const std::string where = "variant " + std::to_string(index) + " (" + variant.description +
                              (ground_truth_poses ? ", ground-truth poses" : ", tracking") +
                              "); rerun with STILLMAP_HOSTILE_SEED=" + std::to_string(kSeed) +
                              "\n  stillmap " + arguments + "\n";
    std::string output;
    const int status = RunStillmap(arguments, &output, HostilePrefix());
    ASSERT_TRUE(status == 0 || status == 1 || status == 2)
        << where << "exit status " << status << " (a signal, a hang or a sanitizer)\n"
        << output;
    for (const std::string& marker : kInternalMarkers) {
      EXPECT_EQ(output.find(marker), std::string::npos)
          << where << "internal message '" << marker << "':\n"
          << output;
    }
    if (status == 0) {
      for (const std::string& name : kAlwaysWritten) {
        EXPECT_TRUE(fs::is_regular_file(out + "/" + name, error)) << where << name << " missing\n"
                                                                  << output;
      }
      EXPECT_TRUE(nlohmann::json::accept(ReadText(out + "/report.json"))) << where;
      EXPECT_FALSE(ReadCloud(out + "/map.ply").empty()) << where << "an empty map succeeded";
    } else {
      const std::vector<std::string> lines = Lines(output);
      ASSERT_FALSE(lines.empty()) << where << "no message";
      const std::string expected = status == 2 ? "stillmap: error: " : "stillmap: failed: ";
      EXPECT_EQ(lines.back().rfind(expected, 0), 0u) << where << output;
      for (const std::string& name : kAlwaysWritten) {
        if (std::find(earlier.begin(), earlier.end(), name) != earlier.end()) continue;
        EXPECT_FALSE(fs::exists(fs::symlink_status(out + "/" + name, error)))
            << where << name << " left behind\n"
            << output;
      }
      if (!earlier_report.empty()) {
        EXPECT_EQ(ReadText(out + "/report.json"), earlier_report)
            << where << "the earlier build's outputs changed\n"
            << output;
      }
    }
    // The other commands read the same files.
    const std::string info = "info " + sequence;
    const int info_status = RunStillmap(info, &output, HostilePrefix());
    EXPECT_TRUE(info_status == 0 || info_status == 2) << where << info << ": " << output;
    const std::string eval = "eval " + sequence + "/groundtruth.txt " + sequence +
                             "/groundtruth.txt --plot " + (dir / "plot.png");
    const int eval_status = RunStillmap(eval, &output, HostilePrefix());
    EXPECT_TRUE(eval_status == 0 || eval_status == 1 || eval_status == 2)
        << where << eval << ": " << output;
  }

  void RunFamily(size_t family, const std::function<Variant(Generator&)>& make) {
    Generator generator(family);
    for (size_t i = 0; i < kVariants; ++i) {
      const Variant variant = make(generator);
      Check(i, variant, generator.Below(3) != 0);
      if (HasFatalFailure()) return;
    }
  }
};

TEST_F(HostileInputTest, ListFiles) { RunFamily(1, ListVariant); }
TEST_F(HostileInputTest, Numbers) { RunFamily(2, NumberVariant); }
TEST_F(HostileInputTest, Images) { RunFamily(3, ImageVariant); }
TEST_F(HostileInputTest, FileSystem) { RunFamily(4, FileSystemVariant); }
TEST_F(HostileInputTest, Options) { RunFamily(5, OptionVariant); }

}  // namespace
}  // namespace stillmap
