#include "stillmap/io/image_io.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>

#include "stillmap/io/error.h"
#include "test_util.h"

namespace stillmap {
namespace {

using testing::TempDir;

void Truncate(const std::string& path, double keep_fraction) {
  const auto size = std::filesystem::file_size(path);
  std::filesystem::resize_file(path, static_cast<uintmax_t>(size * keep_fraction));
}

using testing::ErrorOf;

TEST(ImageIoTest, DepthIsConvertedToMetres) {
  TempDir dir;
  cv::Mat depth(4, 5, CV_16UC1, cv::Scalar(0));
  depth.at<std::uint16_t>(1, 2) = 10000;
  cv::imwrite(dir / "d.png", depth);
  const cv::Mat metres = ReadDepthImage(dir / "d.png", 5000.0);
  ASSERT_EQ(metres.type(), CV_32FC1);
  EXPECT_FLOAT_EQ(metres.at<float>(1, 2), 2.0f);
  EXPECT_FLOAT_EQ(metres.at<float>(0, 0), 0.0f);
}

TEST(ImageIoTest, ColorPngAndJpegDecode) {
  TempDir dir;
  cv::Mat color(48, 64, CV_8UC3, cv::Scalar(10, 20, 30));
  cv::imwrite(dir / "c.png", color);
  cv::imwrite(dir / "c.jpg", color);
  EXPECT_EQ(ReadColorImage(dir / "c.png").at<cv::Vec3b>(5, 5), cv::Vec3b(10, 20, 30));
  EXPECT_EQ(ReadColorImage(dir / "c.jpg").size(), color.size());
}

TEST(ImageIoTest, TruncatedFilesAreRefused) {
  TempDir dir;
  cv::Mat noise(120, 160, CV_16UC1);
  cv::randu(noise, 0, 60000);
  cv::imwrite(dir / "d.png", noise);
  Truncate(dir / "d.png", 0.6);
  EXPECT_NE(ErrorOf([&] { ReadDepthImage(dir / "d.png", 5000.0); }).find("truncated PNG"),
            std::string::npos);
  cv::Mat color(120, 160, CV_8UC3);
  cv::randu(color, 0, 255);
  cv::imwrite(dir / "c.jpg", color);
  Truncate(dir / "c.jpg", 0.7);
  EXPECT_NE(ErrorOf([&] { ReadColorImage(dir / "c.jpg"); }).find("truncated JPEG"),
            std::string::npos);
}

TEST(ImageIoTest, EightBitDepthIsRefused) {
  TempDir dir;
  cv::imwrite(dir / "d8.png", cv::Mat(4, 4, CV_8UC1, cv::Scalar(7)));
  const std::string error = ErrorOf([&] { ReadDepthImage(dir / "d8.png", 5000.0); });
  EXPECT_NE(error.find("8 bits"), std::string::npos) << error;
  EXPECT_NE(error.find("d8.png"), std::string::npos) << error;
}

TEST(ImageIoTest, MissingAndNonImageFiles) {
  TempDir dir;
  EXPECT_NE(ErrorOf([&] { ReadColorImage(dir / "none.png"); }).find("no such file"),
            std::string::npos);
  testing::WriteText(dir / "text.png", "hello, not an image");
  EXPECT_NE(ErrorOf([&] { ReadColorImage(dir / "text.png"); }).find("not a PNG or JPEG"),
            std::string::npos);
}

}  // namespace
}  // namespace stillmap
