// The output set: staged aside, swapped in whole, rolled back, locked, recovered after a kill.
#include "stillmap/io/output_files.h"

#include <gtest/gtest.h>
#include <sys/stat.h>

#include <filesystem>

#include "stillmap/io/error.h"
#include "stillmap/io/input_files.h"
#include "test_util.h"

namespace stillmap {
namespace {

namespace fs = std::filesystem;
using testing::ReadText;
using testing::TempDir;
using testing::WriteText;

const std::vector<std::string> kNames = {"a.txt", "b.txt", "sub/"};

TEST(OutputSetTest, NothingAppearsBeforeCommitAndEverythingAfter) {
  TempDir dir;
  const std::string out = dir / "out";
  {
    OutputSet set(out, kNames);
    WriteText(set.TemporaryPath("a.txt"), "new a");
    WriteText(set.TemporaryPath("sub/x.png"), "new x");
    EXPECT_FALSE(fs::exists(out + "/a.txt"));
    EXPECT_FALSE(fs::exists(out + "/sub"));
    set.Commit();
  }
  EXPECT_EQ(ReadText(out + "/a.txt"), "new a");
  EXPECT_EQ(ReadText(out + "/sub/x.png"), "new x");
  EXPECT_FALSE(fs::exists(out + "/.stillmap-staging"));
}

TEST(OutputSetTest, ARerunReplacesTheWholeSetAndNothingElse) {
  TempDir dir;
  const std::string out = dir / "out";
  fs::create_directories(out + "/sub");
  WriteText(out + "/a.txt", "old a");
  WriteText(out + "/b.txt", "old b");  // not written again: must go
  WriteText(out + "/sub/old.png", "old");
  WriteText(out + "/notes.txt", "the user's");
  {
    OutputSet set(out, kNames);
    WriteText(set.TemporaryPath("a.txt"), "new a");
    set.Commit();
  }
  EXPECT_EQ(ReadText(out + "/a.txt"), "new a");
  EXPECT_FALSE(fs::exists(out + "/b.txt"));
  EXPECT_FALSE(fs::exists(out + "/sub"));
  EXPECT_EQ(ReadText(out + "/notes.txt"), "the user's");
}

TEST(OutputSetTest, WithoutCommitTheEarlierSetStaysAndANewFolderGoes) {
  TempDir dir;
  const std::string out = dir / "out";
  fs::create_directories(out);
  WriteText(out + "/a.txt", "old a");
  {
    OutputSet set(out, kNames);
    WriteText(set.TemporaryPath("a.txt"), "new a");
  }
  EXPECT_EQ(ReadText(out + "/a.txt"), "old a");
  EXPECT_FALSE(fs::exists(out + "/.stillmap-staging"));
  {
    OutputSet set(dir / "fresh", kNames);
    WriteText(set.TemporaryPath("a.txt"), "new a");
  }
  EXPECT_FALSE(fs::exists(dir / "fresh"));
}

TEST(OutputSetTest, AFailedSwapIsRolledBack) {
  TempDir dir;
  const std::string out = dir / "out";
  fs::create_directories(out);
  WriteText(out + "/a.txt", "old a");
  WriteText(out + "/b.txt", "old b");
  OutputSet set(out, kNames);
  WriteText(set.TemporaryPath("a.txt"), "new a");
  WriteText(set.TemporaryPath("b.txt"), "new b");
  // The swap fails after the earlier set was moved aside: its marker cannot be written (a folder
  // has its name; permissions would not stop root).
  fs::create_directories(out + "/.stillmap-previous/.all-moved");
  EXPECT_THROW(set.Commit(), std::runtime_error);
  EXPECT_EQ(ReadText(out + "/a.txt"), "old a");
  EXPECT_EQ(ReadText(out + "/b.txt"), "old b");
  EXPECT_FALSE(fs::exists(out + "/.stillmap-previous"));
}

TEST(OutputSetTest, ASecondSetOnTheSameFolderIsRefused) {
  TempDir dir;
  const std::string out = dir / "out";
  OutputSet first(out, kNames);
  try {
    OutputSet second(out, kNames);
    FAIL() << "a second set was allowed";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("another stillmap run"), std::string::npos) << e.what();
  }
}

TEST(OutputSetTest, AFolderInTheWayOfAFileIsRefused) {
  TempDir dir;
  const std::string out = dir / "out";
  fs::create_directories(out + "/a.txt");
  EXPECT_THROW(OutputSet(out, kNames), InputError);
  EXPECT_TRUE(fs::is_directory(out + "/a.txt"));
}

// A run killed while swapping: the earlier set comes back whole, whichever half it was in.
TEST(OutputSetTest, AnInterruptedSwapIsRolledBackByTheNextRun) {
  for (const bool all_moved : {false, true}) {
    TempDir dir;
    const std::string out = dir / "out";
    fs::create_directories(out + "/.stillmap-previous");
    fs::create_directories(out + "/.stillmap-staging");
    WriteText(out + "/.stillmap-previous/a.txt", "old a");
    if (all_moved) {
      WriteText(out + "/.stillmap-previous/b.txt", "old b");
      WriteText(out + "/.stillmap-previous/.all-moved", "");
      WriteText(out + "/a.txt", "new a, moved in before the kill");
      WriteText(out + "/.stillmap-staging/b.txt", "new b, not yet moved");
    } else {
      WriteText(out + "/b.txt", "old b");  // not yet moved aside
      WriteText(out + "/.stillmap-staging/a.txt", "new a");
    }
    WriteText(out + "/.a.txt.tmp", "what an earlier version left");
    OutputSet set(out, kNames);
    EXPECT_FALSE(set.recovery_note().empty());
    EXPECT_EQ(ReadText(out + "/a.txt"), "old a") << all_moved;
    EXPECT_EQ(ReadText(out + "/b.txt"), "old b") << all_moved;
    EXPECT_FALSE(fs::exists(out + "/.stillmap-previous"));
    EXPECT_FALSE(fs::exists(out + "/.a.txt.tmp"));
    EXPECT_TRUE(fs::is_empty(set.staging_dir()));
  }
}

TEST(InputFilesTest, FoldersFifosAndLinkLoopsAreNamed) {
  TempDir dir;
  auto message = [](const std::string& path) {
    try {
      CheckInputFile(path, "list");
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  WriteText(dir / "file.txt", "x");
  EXPECT_EQ(message(dir / "file.txt"), "accepted");
  EXPECT_NE(message(dir / "none.txt").find("no such file"), std::string::npos);
  fs::create_directory(dir / "folder.txt");
  EXPECT_NE(message(dir / "folder.txt").find("is a folder"), std::string::npos);
  ASSERT_EQ(::mkfifo((dir / "fifo.txt").c_str(), 0644), 0);
  EXPECT_NE(message(dir / "fifo.txt").find("FIFO"), std::string::npos);
  fs::create_symlink(dir / "loop.txt", dir / "loop.txt");
  EXPECT_NE(message(dir / "loop.txt").find("symbolic links"), std::string::npos);
  EXPECT_TRUE(PathExists(dir / "loop.txt"));
  EXPECT_FALSE(PathExists(dir / "none.txt"));
}

}  // namespace
}  // namespace stillmap
