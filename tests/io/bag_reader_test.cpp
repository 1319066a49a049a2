// ROS 1 bags written by ROS's own writer (../shared/data/bags, Debian's python3-rosbag) read back
// against the sequence they were written from: header stamps equal rgb.txt's, raw colour equals
// the PNG, depth equals the depth PNG's metres; a bag cut short maps what it holds and says so.
#include "stillmap/io/bag_reader.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <opencv2/imgcodecs.hpp>

#include "bag/ros_messages.h"
#include "bag_test_util.h"
#include "stillmap/io/error.h"
#include "test_util.h"

namespace stillmap {
namespace {

namespace fs = std::filesystem;

class BagReaderTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const std::optional<std::string> sequence = testing::SharedSequence("tum_fr3_teddy_200");
    if (!sequence) GTEST_SKIP() << "tum_fr3_teddy_200 not in ../shared/data";
    sequence_ = *sequence;
  }
  std::string sequence_;
};

TEST_F(BagReaderTest, RawTumBagWithBz2ChunksGivesTheSequencesImages) {
  const std::optional<std::string> path = testing::SharedBag("teddy_tum_raw.bag");
  if (!path) GTEST_SKIP() << "bags/teddy_tum_raw.bag not in ../shared/data";
  ASSERT_TRUE(LooksLikeBag(*path));
  const std::unique_ptr<BagReader> bag = OpenBag(*path);
  ASSERT_EQ(bag->serialization(), BagSerialization::kRos1);
  const Scanned scanned = ScanAll(*bag);
  EXPECT_FALSE(bag->truncated());
  EXPECT_TRUE(bag->warnings().empty());
  const auto& colour = scanned.data.at("/camera/rgb/image_color");
  const auto& depth = scanned.data.at("/camera/depth/image");
  ASSERT_EQ(colour.size(), 12u);
  ASSERT_GE(depth.size(), 12u);  // the depth stream's own rate: a frame more in the span
  ASSERT_EQ(scanned.data.count("/camera/rgb/camera_info"), 1u);
  const auto rgb = ListOf(sequence_, "rgb.txt"), depths = ListOf(sequence_, "depth.txt");
  for (size_t i = 0; i < colour.size(); ++i) {
    RosImage image;
    std::string error;
    ASSERT_TRUE(
        DecodeRosImage(colour[i].data(), colour[i].size(), BagSerialization::kRos1, &image, &error))
        << error;
    EXPECT_EQ(image.encoding, "rgb8");
    const auto file = rgb.find(Stamp(image.header.stamp));
    ASSERT_NE(file, rgb.end()) << Stamp(image.header.stamp) << " is no rgb.txt stamp";
    const cv::Mat expected = cv::imread(sequence_ + "/" + file->second, cv::IMREAD_COLOR);
    EXPECT_EQ(cv::norm(ColorFromRosImage(image, "test"), expected, cv::NORM_INF), 0.0);
  }
  for (const auto& bytes : depth) {
    RosImage image;
    std::string error;
    ASSERT_TRUE(
        DecodeRosImage(bytes.data(), bytes.size(), BagSerialization::kRos1, &image, &error));
    EXPECT_EQ(image.encoding, "32FC1");
    const auto file = depths.find(Stamp(image.header.stamp));
    ASSERT_NE(file, depths.end());
    cv::Mat expected;
    cv::imread(sequence_ + "/" + file->second, cv::IMREAD_UNCHANGED)
        .convertTo(expected, CV_32F, 1.0 / 5000.0);
    EXPECT_LT(cv::norm(DepthFromRosImage(image, 0.001, "test"), expected, cv::NORM_INF), 1e-6);
  }
  // Read again from where the scan found it: the same bytes.
  const BagMessage& last = scanned.by_topic.at("/camera/depth/image").back();
  EXPECT_EQ(bag->Read(last.position), depth.back());
}

TEST_F(BagReaderTest, RealsenseBagWithLz4ChunksGivesJpegColourAndMillimetreDepth) {
  const std::optional<std::string> path = testing::SharedBag("teddy_realsense_lz4.bag");
  if (!path) GTEST_SKIP() << "bags/teddy_realsense_lz4.bag not in ../shared/data";
  const std::unique_ptr<BagReader> bag = OpenBag(*path);
  const Scanned scanned = ScanAll(*bag);
  EXPECT_FALSE(bag->truncated());
  const auto& colour = scanned.data.at("/camera/camera/color/image_raw/compressed");
  const auto& depth = scanned.data.at("/camera/camera/aligned_depth_to_color/image_raw");
  ASSERT_EQ(colour.size(), 30u);
  ASSERT_GE(depth.size(), 30u);
  const auto rgb = ListOf(sequence_, "rgb.txt"), depths = ListOf(sequence_, "depth.txt");
  RosCompressedImage jpeg;
  std::string error;
  ASSERT_TRUE(DecodeRosCompressedImage(colour[0].data(), colour[0].size(), BagSerialization::kRos1,
                                       &jpeg, &error));
  const cv::Mat expected =
      cv::imread(sequence_ + "/" + rgb.at(Stamp(jpeg.header.stamp)), cv::IMREAD_COLOR);
  const cv::Mat decoded = ColorFromRosCompressed(jpeg, "test");
  ASSERT_EQ(decoded.size(), expected.size());
  EXPECT_LT(cv::norm(decoded, expected, cv::NORM_L1) / static_cast<double>(expected.total() * 3),
            4.0);  // JPEG's loss, grey levels per channel on average
  RosImage millimetres;
  ASSERT_TRUE(DecodeRosImage(depth[0].data(), depth[0].size(), BagSerialization::kRos1,
                             &millimetres, &error));
  EXPECT_EQ(millimetres.encoding, "16UC1");
  cv::Mat truth;
  cv::imread(sequence_ + "/" + depths.at(Stamp(millimetres.header.stamp)), cv::IMREAD_UNCHANGED)
      .convertTo(truth, CV_32F, 1.0 / 5000.0);
  EXPECT_LE(cv::norm(DepthFromRosImage(millimetres, 0.001, "test"), truth, cv::NORM_INF),
            0.0005 + 1e-6);  // rounded to the millimetre
}

TEST_F(BagReaderTest, ABagCutShortReadsWhatItHoldsAndSaysTruncated) {
  const std::optional<std::string> path = testing::SharedBag("teddy_realsense_lz4.bag");
  if (!path) GTEST_SKIP() << "bags/teddy_realsense_lz4.bag not in ../shared/data";
  testing::TempDir dir;
  const std::string cut = dir / "cut.bag";
  fs::copy_file(*path, cut);
  fs::resize_file(cut, fs::file_size(*path) * 6 / 10);
  const std::unique_ptr<BagReader> bag = OpenBag(cut);
  const Scanned scanned = ScanAll(*bag);
  EXPECT_TRUE(bag->truncated());
  ASSERT_FALSE(bag->warnings().empty());
  EXPECT_NE(bag->warnings().back().find("truncated"), std::string::npos);
  EXPECT_NE(bag->warnings().back().find("cut.bag"), std::string::npos);
  const size_t kept = scanned.data.at("/camera/camera/aligned_depth_to_color/image_raw").size();
  EXPECT_GT(kept, 5u);
  EXPECT_LT(kept, 31u);
}

// MCAP (ROS 2, CDR messages) with zstd chunks and with lz4 chunks: the same stamps and images.
TEST_F(BagReaderTest, McapWithZstdAndLz4ChunksGivesTheSequencesImages) {
  const auto rgb = ListOf(sequence_, "rgb.txt"), depths = ListOf(sequence_, "depth.txt");
  for (const char* name : {"teddy_realsense.mcap", "teddy_realsense_lz4_bgr.mcap"}) {
    const std::optional<std::string> path = testing::SharedBag(name);
    if (!path) GTEST_SKIP() << "bags/" << name << " not in ../shared/data";
    ASSERT_TRUE(LooksLikeBag(*path));
    const std::unique_ptr<BagReader> bag = OpenBag(*path);
    ASSERT_EQ(bag->serialization(), BagSerialization::kCdr);
    const Scanned scanned = ScanAll(*bag);
    EXPECT_FALSE(bag->truncated()) << name;
    EXPECT_TRUE(bag->warnings().empty()) << name;
    const auto& depth = scanned.data.at("/camera/camera/aligned_depth_to_color/image_raw");
    ASSERT_GE(depth.size(), 8u) << name;
    RosImage image;
    std::string error;
    ASSERT_TRUE(
        DecodeRosImage(depth[0].data(), depth[0].size(), BagSerialization::kCdr, &image, &error))
        << error;
    cv::Mat truth;
    cv::imread(sequence_ + "/" + depths.at(Stamp(image.header.stamp)), cv::IMREAD_UNCHANGED)
        .convertTo(truth, CV_32F, 1.0 / 5000.0);
    // 16UC1 rounds to the millimetre; 32FC1 holds the metres.
    EXPECT_LE(cv::norm(DepthFromRosImage(image, 0.001, "test"), truth, cv::NORM_INF), 0.0005 + 1e-6)
        << name;
    const BagMessage& last =
        scanned.by_topic.at("/camera/camera/aligned_depth_to_color/image_raw").back();
    EXPECT_EQ(bag->Read(last.position), depth.back()) << name;
    const auto raw = scanned.data.find("/camera/camera/color/image_raw");
    if (raw != scanned.data.end()) {
      RosImage color;
      ASSERT_TRUE(DecodeRosImage(raw->second[0].data(), raw->second[0].size(),
                                 BagSerialization::kCdr, &color, &error));
      EXPECT_EQ(color.encoding, "bgr8");
      const cv::Mat expected =
          cv::imread(sequence_ + "/" + rgb.at(Stamp(color.header.stamp)), cv::IMREAD_COLOR);
      EXPECT_EQ(cv::norm(ColorFromRosImage(color, "test"), expected, cv::NORM_INF), 0.0);
    }
  }
}

TEST(BagOpenTest, NotABagIsRefusedNamingTheFile) {
  testing::TempDir dir;
  const std::string path = dir / "garbage.bag";
  std::ofstream(path) << "#ROSBAG V2.0\nthis is not a bag header record at all";
  EXPECT_THROW(
      {
        try {
          OpenBag(path);
        } catch (const InputError& e) {
          EXPECT_NE(std::string(e.what()).find("garbage.bag"), std::string::npos) << e.what();
          throw;
        }
      },
      InputError);
  std::ofstream(dir / "text.bag") << "hello";
  EXPECT_FALSE(LooksLikeBag(dir / "text.bag"));
  EXPECT_THROW(OpenBag(dir / "text.bag"), InputError);
  std::ofstream(dir / "old.bag") << "#ROSBAG V1.2\n";
  EXPECT_THROW(OpenBag(dir / "old.bag"), InputError);
}

}  // namespace
}  // namespace stillmap
