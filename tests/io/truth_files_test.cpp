#include "stillmap/io/truth_files.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <opencv2/imgcodecs.hpp>

#include "stillmap/io/error.h"
#include "test_util.h"

namespace stillmap {
namespace {

using testing::ErrorOf;
using testing::TempDir;
using testing::WriteText;

TEST(TruthFilesTest, ObjectPosesAreReadWithTheirPoses) {
  TempDir dir;
  WriteText(dir / "objects.txt",
            "# timestamp object_id name tx ty tz qx qy qz qw\n"
            "1.5 100 person_0 1 2 0 0 0 0.7071067811865476 0.7071067811865476\n"
            "\n"
            "1.6 101 person_1 -1 0.5 0 0 0 0 1\n");
  const std::vector<ObjectPose> poses = ReadObjectPoses(dir / "objects.txt");
  ASSERT_EQ(poses.size(), 2u);
  EXPECT_DOUBLE_EQ(poses[0].time, 1.5);
  EXPECT_EQ(poses[0].id, "100");
  EXPECT_EQ(poses[0].name, "person_0");
  EXPECT_TRUE(poses[0].world_from_object.translation().isApprox(Eigen::Vector3d(1, 2, 0)));
  // 90 degrees about z: x goes to y.
  EXPECT_TRUE((poses[0].world_from_object.linear() * Eigen::Vector3d::UnitX())
                  .isApprox(Eigen::Vector3d::UnitY(), 1e-12));
  EXPECT_EQ(poses[1].name, "person_1");
}

// A malformed line is an error naming the file and the line, never skipped.
TEST(TruthFilesTest, MalformedObjectLinesNameTheFileAndLine) {
  const std::vector<std::string> bad_lines = {
      "1.5 100 person_0 1 2 0 0 0 0",        // a field missing
      "1.5 100 person_0 1 2 nan 0 0 0 1",    // not finite
      "1.5 100 person_0 1 2 0 0 0 0 1 7",    // a field too many
      "1.5 100 person_0 1 2 0 0 0 0.2 0.2",  // quaternion far from unit length
      "x 100 person_0 1 2 0 0 0 0 1"};       // timestamp not a number
  for (const std::string& bad : bad_lines) {
    TempDir dir;
    WriteText(dir / "objects.txt", "# header\n1.4 100 person_0 1 2 0 0 0 0 1\n" + bad + "\n");
    const std::string error = ErrorOf([&] { ReadObjectPoses(dir / "objects.txt"); });
    EXPECT_NE(error.find("objects.txt:3"), std::string::npos) << bad << " -> " << error;
  }
  EXPECT_NE(ErrorOf([] { ReadObjectPoses("/nonexistent/objects.txt"); }).find("objects.txt"),
            std::string::npos);
}

TEST(TruthFilesTest, MasksAreFoundByTimestamp) {
  TempDir dir;
  EXPECT_FALSE(TruthMasks(dir.path()).available());  // no masks.txt: no masks, no error
  std::filesystem::create_directories(dir / "masks");
  cv::Mat mask(4, 6, CV_8UC1, cv::Scalar(0));
  mask.at<std::uint8_t>(1, 2) = 255;
  ASSERT_TRUE(cv::imwrite(dir / "masks/1.000000.png", mask));
  WriteText(dir / "masks.txt", "# timestamp filename\n1.000000 masks/1.000000.png\n");
  const TruthMasks masks(dir.path());
  ASSERT_TRUE(masks.available());
  const cv::Mat read = masks.Get(1.0005);
  ASSERT_FALSE(read.empty());
  EXPECT_EQ(read.at<std::uint8_t>(1, 2), 255);
  EXPECT_TRUE(masks.Get(1.01).empty());  // nothing within 1 ms
  WriteText(dir / "masks/1.000000.png", "not a png");
  EXPECT_NE(ErrorOf([&] { masks.Get(1.0); }).find("1.000000.png"), std::string::npos);
}

}  // namespace
}  // namespace stillmap
