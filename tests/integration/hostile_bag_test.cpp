// Damaged recorded bags (issue 28) through the binary: byte flips, cuts, zeroed spans and
// impossible lengths in copies of a shared ROS 1 bag (lz4 chunks), MCAP file (zstd chunks) and
// ROS 2 sqlite3 file.
// Every run ends with exit 0, 1 or 2 within the time limit (run it under the sanitizer preset too:
// scripts/sanitize.sh), an error names the bag, and no library's own message reaches the user.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>

#include "hostile_corpus.h"

namespace stillmap {
namespace {

std::vector<char> ReadBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// One damaged copy of `bag`, as the generator picks it.
std::vector<char> Damaged(std::vector<char> bag, Generator& generator) {
  switch (generator.Below(5)) {
    case 0:  // bits flipped anywhere
      for (size_t n = 1 + generator.Below(20); n > 0; --n) {
        bag[generator.Below(bag.size())] ^= static_cast<char>(1U << generator.Below(8));
      }
      break;
    case 1:  // bytes replaced among the first records (bag header, connections, first chunk)
      for (size_t n = 1 + generator.Below(8); n > 0; --n) {
        bag[generator.Below(std::min<size_t>(bag.size(), 20000))] =
            static_cast<char>(generator.Below(256));
      }
      break;
    case 2: {  // a length field made impossible
      const size_t at = generator.Below(bag.size() - 4);
      const std::vector<std::string> lengths = {std::string("\xff\xff\xff\xff", 4),
                                                std::string("\x00\x00\x00\x00", 4),
                                                std::string("\xff\xff\xff\x7f", 4)};
      const std::string& length = generator.Pick(lengths);
      std::copy(length.begin(), length.end(), bag.begin() + static_cast<std::ptrdiff_t>(at));
      break;
    }
    case 3:  // cut short
      bag.resize(generator.Below(bag.size()));
      break;
    default: {  // a span zeroed
      const size_t at = generator.Below(bag.size());
      const size_t end = std::min(bag.size(), at + 1 + generator.Below(5000));
      std::fill(bag.begin() + static_cast<std::ptrdiff_t>(at),
                bag.begin() + static_cast<std::ptrdiff_t>(end), '\0');
    }
  }
  return bag;
}

void ExpectDamagedCopiesHandled(const std::string& name, size_t family) {
  const std::optional<std::string> source = testing::SharedBag(name);
  if (!source) GTEST_SKIP() << "bags/" << name << " not in ../shared/data";
  const std::vector<char> bag = ReadBytes(*source);
  testing::TempDir dir;
  Generator generator(family);
  for (size_t variant = 0; variant < kVariants; ++variant) {
    const std::vector<char> damaged = Damaged(bag, generator);
    const std::string path = dir / ("case" + std::to_string(variant) + ".bag");
    std::ofstream(path, std::ios::binary)
        .write(damaged.data(), static_cast<std::streamsize>(damaged.size()));
    // Every fifth variant is built (a few seconds each); the others are described.
    const std::string command =
        variant % 5 == 0 ? "build " + path + " -o " + (dir / "out") + " --quiet --detector none"
                         : "info " + path;
    std::string output;
    const int status = testing::RunStillmap(command, &output, HostilePrefix());
    EXPECT_TRUE(status == 0 || status == 1 || status == 2) << command << ": exit " << status << "\n"
                                                           << output;
    if (status != 0) {
      EXPECT_NE(output.find(path), std::string::npos) << command << ":\n" << output;
    }
    for (const std::string& marker : kInternalMarkers) {
      EXPECT_EQ(output.find(marker), std::string::npos) << command << ":\n" << output;
    }
    std::filesystem::remove(path);
  }
}

TEST(HostileBagTest, DamagedRosOneBagsNeverCrashAndAreNamed) {
  ExpectDamagedCopiesHandled("teddy_realsense_lz4.bag", 28);
}

TEST(HostileBagTest, DamagedMcapFilesNeverCrashAndAreNamed) {
  ExpectDamagedCopiesHandled("teddy_realsense.mcap", 29);
}

TEST(HostileBagTest, DamagedSqliteBagsNeverCrashAndAreNamed) {
  ExpectDamagedCopiesHandled("teddy_realsense_db3/teddy_realsense_db3_0.db3", 30);
}

}  // namespace
}  // namespace stillmap
