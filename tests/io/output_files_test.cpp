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

// One committed run of kind "test" that writes `files` (name, text).
void CommitRun(const std::string& out,
               const std::vector<std::pair<std::string, std::string>>& files) {
  OutputSet set(out, "test", kNames);
  for (const auto& [name, text] : files) WriteText(set.TemporaryPath(name), text);
  set.Commit();
}

TEST(OutputSetTest, NothingAppearsBeforeCommitAndEverythingAfter) {
  TempDir dir;
  const std::string out = dir / "out";
  {
    OutputSet set(out, "test", kNames);
    WriteText(set.TemporaryPath("a.txt"), "new a");
    WriteText(set.TemporaryPath("sub/x.png"), "new x");
    EXPECT_FALSE(fs::exists(out + "/a.txt"));
    EXPECT_FALSE(fs::exists(out + "/sub"));
    set.Commit();
  }
  EXPECT_EQ(ReadText(out + "/a.txt"), "new a");
  EXPECT_EQ(ReadText(out + "/sub/x.png"), "new x");
  EXPECT_FALSE(fs::exists(out + "/.stillmap-staging"));
  EXPECT_EQ(ReadText(out + "/.stillmap-test-outputs")
                .substr(ReadText(out + "/.stillmap-test-outputs").find('\n') + 1),
            "a.txt\nsub/x.png\n");
}

// A rerun removes exactly what the last run wrote and did not write again: never a file a user put
// beside the outputs or inside an output folder.
TEST(OutputSetTest, ARerunReplacesWhatTheLastRunWroteAndNothingElse) {
  TempDir dir;
  const std::string out = dir / "out";
  CommitRun(out, {{"a.txt", "old a"}, {"b.txt", "old b"}, {"sub/x.png", "old x"}});
  WriteText(out + "/notes.txt", "the user's");
  WriteText(out + "/sub/mine.png", "the user's");
  {
    OutputSet set(out, "test", kNames);
    EXPECT_EQ(set.ForeignNames(), (std::vector<std::string>{"notes.txt", "sub/mine.png"}));
    WriteText(set.TemporaryPath("a.txt"), "new a");
    EXPECT_TRUE(set.PlanSetAside().empty());
    set.Commit();
  }
  EXPECT_EQ(ReadText(out + "/a.txt"), "new a");
  EXPECT_FALSE(fs::exists(out + "/b.txt"));
  EXPECT_FALSE(fs::exists(out + "/sub/x.png"));
  EXPECT_EQ(ReadText(out + "/notes.txt"), "the user's");
  EXPECT_EQ(ReadText(out + "/sub/mine.png"), "the user's");
}

// A file with an output's name that no run wrote (the folder has no record of it) is kept,
// renamed, and the plan names it before the swap.
TEST(OutputSetTest, AFileNoRunWroteIsKeptAside) {
  TempDir dir;
  const std::string out = dir / "out";
  fs::create_directories(out + "/sub");
  WriteText(out + "/a.txt", "the user's a");
  WriteText(out + "/a.txt.before-stillmap", "an older one");
  WriteText(out + "/sub/x.png", "the user's x");
  {
    OutputSet set(out, "test", kNames);
    WriteText(set.TemporaryPath("a.txt"), "new a");
    const std::vector<OutputSet::SetAside> plan = set.PlanSetAside({"sub/x.png"});
    ASSERT_EQ(plan.size(), 2u);
    EXPECT_EQ(plan[0].name, "a.txt");
    EXPECT_EQ(plan[0].kept_as, "a.txt.before-stillmap-2");
    EXPECT_EQ(plan[1].kept_as, "sub/x.png.before-stillmap");
    WriteText(set.TemporaryPath("sub/x.png"), "new x");
    set.Commit();
  }
  EXPECT_EQ(ReadText(out + "/a.txt"), "new a");
  EXPECT_EQ(ReadText(out + "/a.txt.before-stillmap-2"), "the user's a");
  EXPECT_EQ(ReadText(out + "/a.txt.before-stillmap"), "an older one");
  EXPECT_EQ(ReadText(out + "/sub/x.png.before-stillmap"), "the user's x");
  // The next run's files are its own: replaced without a copy.
  CommitRun(out, {{"a.txt", "newer a"}});
  EXPECT_EQ(ReadText(out + "/a.txt"), "newer a");
  EXPECT_FALSE(fs::exists(out + "/a.txt.before-stillmap-3"));
}

TEST(OutputSetTest, WithoutCommitTheEarlierSetStaysAndANewFolderGoes) {
  TempDir dir;
  const std::string out = dir / "out";
  CommitRun(out, {{"a.txt", "old a"}});
  {
    OutputSet set(out, "test", kNames);
    WriteText(set.TemporaryPath("a.txt"), "new a");
  }
  EXPECT_EQ(ReadText(out + "/a.txt"), "old a");
  EXPECT_FALSE(fs::exists(out + "/.stillmap-staging"));
  {
    OutputSet set(dir / "fresh", "test", kNames);
    WriteText(set.TemporaryPath("a.txt"), "new a");
  }
  EXPECT_FALSE(fs::exists(dir / "fresh"));
}

TEST(OutputSetTest, ASecondSetOnTheSameFolderIsRefused) {
  TempDir dir;
  const std::string out = dir / "out";
  OutputSet first(out, "test", kNames);
  try {
    OutputSet second(out, "test", kNames);
    FAIL() << "a second set was allowed";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("another stillmap run"), std::string::npos) << e.what();
  }
}

TEST(OutputSetTest, AFolderInTheWayOfAFileIsRefused) {
  TempDir dir;
  const std::string out = dir / "out";
  fs::create_directories(out + "/a.txt");
  EXPECT_THROW(OutputSet(out, "test", kNames), InputError);
  EXPECT_TRUE(fs::is_directory(out + "/a.txt"));
}

// The lock is never written through a link a user (or an attacker) left at its name.
TEST(OutputSetTest, ALockThatIsASymbolicLinkIsRefused) {
  TempDir dir;
  const std::string out = dir / "out";
  fs::create_directories(out);
  WriteText(dir / "precious.txt", "the user's");
  fs::create_symlink(dir / "precious.txt", out + "/.stillmap.lock");
  try {
    OutputSet set(out, "test", kNames);
    FAIL() << "the link was followed";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("symbolic link"), std::string::npos) << e.what();
  }
  EXPECT_EQ(ReadText(dir / "precious.txt"), "the user's");
}

// A run killed half-way through its swap (here: a.txt moved in, b.txt still staged, the old c.txt
// not yet removed) is completed by the next command that opens the folder: nothing is missing.
TEST(OutputSetTest, AnInterruptedSwapIsCompletedByTheNextCommand) {
  const std::vector<std::string> names = {"a.txt", "b.txt", "c.txt"};
  for (const bool through_a_set : {false, true}) {
    TempDir dir;
    const std::string out = dir / "out";
    {
      OutputSet set(out, "test", names);
      for (const char* name : {"a.txt", "b.txt", "c.txt"})
        WriteText(set.TemporaryPath(name), "old");
      set.Commit();
    }
    fs::create_directories(out + "/.stillmap-staging");
    WriteText(out + "/a.txt", "new a");
    WriteText(out + "/.stillmap-staging/b.txt", "new b");
    WriteText(out + "/.stillmap-test-swap", "# a swap\nwrite\ta.txt\nwrite\tb.txt\n");
    if (through_a_set) {
      OutputSet set(out, "test", names);
      EXPECT_FALSE(set.recovery_note().empty());
    } else {
      EXPECT_FALSE(RecoverOutputFolder(out, "test").empty());
    }
    EXPECT_EQ(ReadText(out + "/a.txt"), "new a");
    EXPECT_EQ(ReadText(out + "/b.txt"), "new b");
    EXPECT_FALSE(fs::exists(out + "/c.txt"));
    EXPECT_FALSE(fs::exists(out + "/.stillmap-test-swap"));
    EXPECT_EQ(RecoverOutputFolder(out, "test"), "");  // nothing left to do
  }
}

// What versions before the record left aside is never moved over a newer file; a record or
// journal naming paths outside the folder is not followed.
TEST(OutputSetTest, StrayAndForgedEntriesTouchNothing) {
  TempDir dir;
  const std::string out = dir / "out";
  fs::create_directories(out + "/.stillmap-previous");
  WriteText(out + "/.stillmap-previous/notes.txt", "stale");
  WriteText(out + "/notes.txt", "newer");
  WriteText(dir / "victim.txt", "the user's");
  WriteText(out + "/.stillmap-test-outputs", "../victim.txt\n/etc/hostname\na.txt\n");
  {
    OutputSet set(out, "test", kNames);
    EXPECT_NE(set.recovery_note().find(".stillmap-previous"), std::string::npos);
    WriteText(set.TemporaryPath("b.txt"), "b");
    set.Commit();
  }
  EXPECT_EQ(ReadText(out + "/notes.txt"), "newer");
  EXPECT_EQ(ReadText(out + "/.stillmap-previous/notes.txt"), "stale");
  EXPECT_EQ(ReadText(dir / "victim.txt"), "the user's");
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
