#include "stillmap/io/file_list.h"

#include <gtest/gtest.h>

#include "stillmap/io/error.h"
#include "test_util.h"

namespace stillmap {
namespace {

using testing::TempDir;
using testing::WriteText;

std::string ErrorOf(const std::string& path) {
  try {
    ReadFileList(path);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST(FileListTest, ReadsEntriesSkippingComments) {
  TempDir dir;
  WriteText(dir / "rgb.txt", "# comment\n\n1.5 rgb/a.png\n2.5\trgb/b.png\n");
  const std::vector<StampedPath> list = ReadFileList(dir / "rgb.txt");
  ASSERT_EQ(list.size(), 2u);
  EXPECT_DOUBLE_EQ(list[1].time, 2.5);
  EXPECT_EQ(list[1].path, "rgb/b.png");
  EXPECT_EQ(list[1].line, 4);
}

TEST(FileListTest, ErrorsNameFileAndLine) {
  TempDir dir;
  WriteText(dir / "bad.txt", "1.0 a.png\nabc b.png\n");
  EXPECT_NE(ErrorOf(dir / "bad.txt").find("bad.txt:2"), std::string::npos);
  WriteText(dir / "unsorted.txt", "1.0 a.png\n3.0 b.png\n2.0 c.png\n");
  const std::string unsorted = ErrorOf(dir / "unsorted.txt");
  EXPECT_NE(unsorted.find("unsorted.txt:3"), std::string::npos) << unsorted;
  EXPECT_NE(unsorted.find("earlier"), std::string::npos) << unsorted;
  WriteText(dir / "dup.txt", "1.0 a.png\n1.0 b.png\n");
  EXPECT_NE(ErrorOf(dir / "dup.txt").find("repeats"), std::string::npos);
  WriteText(dir / "empty.txt", "# nothing\n");
  EXPECT_NE(ErrorOf(dir / "empty.txt").find("no images"), std::string::npos);
  EXPECT_NE(ErrorOf(dir / "missing.txt").find("cannot open"), std::string::npos);
}

TEST(FileListTest, AssociationIsGreedyByTimeDifference) {
  // 1.00 is closest to 1.005 (0.005) and 1.012 would pair with 1.005 (0.007) but is taken second.
  const std::vector<double> a = {1.000, 1.012, 2.000, 3.000};
  const std::vector<double> b = {1.005, 1.020, 2.019, 3.030};
  const auto matches = AssociateTimestamps(a, b, 0.02);
  ASSERT_EQ(matches.size(), 3u);
  EXPECT_EQ(matches[0], std::make_pair(size_t{0}, size_t{0}));
  EXPECT_EQ(matches[1], std::make_pair(size_t{1}, size_t{1}));
  EXPECT_EQ(matches[2], std::make_pair(size_t{2}, size_t{2}));  // 3.000 vs 3.030: too far
}

TEST(FileListTest, ClosestIndex) {
  const std::vector<double> t = {0.0, 1.0, 2.0};
  EXPECT_EQ(FindClosestIndex(t, -5.0), 0u);
  EXPECT_EQ(FindClosestIndex(t, 1.4), 1u);
  EXPECT_EQ(FindClosestIndex(t, 1.6), 2u);
  EXPECT_EQ(FindClosestIndex(t, 9.0), 2u);
}

}  // namespace
}  // namespace stillmap
