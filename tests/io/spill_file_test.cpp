#include "stillmap/io/spill_file.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <random>
#include <stdexcept>
#include <string>

#include "test_util.h"

namespace stillmap {
namespace {

using testing::TempDir;

// Sets TMPDIR for the test's span.
class ScopedTmpdir {
 public:
  explicit ScopedTmpdir(const std::string& folder) {
    if (const char* old = std::getenv("TMPDIR")) old_ = old;
    ::setenv("TMPDIR", folder.c_str(), 1);
  }
  ~ScopedTmpdir() {
    if (old_.empty()) {
      ::unsetenv("TMPDIR");
    } else {
      ::setenv("TMPDIR", old_.c_str(), 1);
    }
  }
  ScopedTmpdir(const ScopedTmpdir&) = delete;
  ScopedTmpdir& operator=(const ScopedTmpdir&) = delete;

 private:
  std::string old_;
};

TEST(SpillFileTest, BlocksReadBackAsWrittenAndTheFileHasNoName) {
  TempDir dir;
  const ScopedTmpdir tmpdir(dir.path());
  SpillFile file("test blocks");
  std::mt19937 random(3);
  std::vector<std::vector<unsigned char>> written;
  std::vector<SpillFile::Block> blocks;
  for (int k = 0; k < 50; ++k) {
    std::vector<unsigned char> bytes(std::uniform_int_distribution<size_t>(0, 70000)(random));
    for (unsigned char& byte : bytes) byte = static_cast<unsigned char>(random());
    blocks.push_back(file.Append(bytes));
    written.push_back(std::move(bytes));
  }
  size_t total = 0;
  for (int k = 49; k >= 0; --k) {  // in any order
    EXPECT_EQ(file.Read(blocks[static_cast<size_t>(k)]), written[static_cast<size_t>(k)]);
    total += written[static_cast<size_t>(k)].size();
  }
  EXPECT_EQ(file.size(), total);
  EXPECT_TRUE(std::filesystem::is_empty(dir.path()));  // nothing left behind, even on a crash
  EXPECT_THROW(file.Read({total - 1, 2}), std::runtime_error);
}

TEST(SpillFileTest, AFolderThatCannotHoldItIsNamedWithWhatToDo) {
  TempDir dir;
  const std::string missing = dir.path() + "/no-such-folder";
  const ScopedTmpdir tmpdir(missing);
  SpillFile file("test blocks");
  try {
    file.Append({1, 2, 3});
    FAIL() << "a temporary file in a missing folder";
  } catch (const std::runtime_error& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find(missing), std::string::npos) << message;
    EXPECT_NE(message.find("test blocks"), std::string::npos) << message;
    EXPECT_NE(message.find("set TMPDIR"), std::string::npos) << message;
  }
}

}  // namespace
}  // namespace stillmap
