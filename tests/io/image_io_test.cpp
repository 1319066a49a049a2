#include "stillmap/io/image_io.h"

#include <gtest/gtest.h>
#include <zlib.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <functional>
#include <opencv2/imgcodecs.hpp>

#include "stillmap/io/error.h"
#include "stillmap/io/trajectory.h"
#include "test_util.h"

namespace stillmap {
namespace {

using testing::TempDir;

void Truncate(const std::string& path, double keep_fraction) {
  const auto size = std::filesystem::file_size(path);
  std::filesystem::resize_file(path, static_cast<uintmax_t>(size * keep_fraction));
}

using testing::ErrorOf;

// The message of a run that failed (std::runtime_error, exit status 1), empty when none.
std::string FailureOf(const std::function<void()>& call) {
  try {
    call();
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "";
}

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

// The library's own words for damage never reach the user: a row filter PNG does not define
// (libpng: "bad adaptive filter value"), a JPEG whose data stops at an early end marker
// (libjpeg: "Premature end of JPEG file" or "Corrupt JPEG data").
TEST(ImageIoTest, DamageIsSaidInTheUsersWords) {
  TempDir dir;
  std::vector<unsigned char> png;
  cv::imencode(".png", cv::Mat(8, 8, CV_16UC1, cv::Scalar(1000)), png,
               {cv::IMWRITE_PNG_COMPRESSION, 0});  // stored deflate blocks: row bytes in the open
  const auto idat = std::search(png.begin(), png.end(), std::begin("IDAT"), std::end("IDAT") - 1);
  ASSERT_NE(idat, png.end());
  const size_t type = static_cast<size_t>(idat - png.begin());
  const size_t length = (size_t{png[type - 4]} << 24) | (size_t{png[type - 3]} << 16) |
                        (size_t{png[type - 2]} << 8) | png[type - 1];
  png[type + 4 + 2 + 5] = 9;  // after zlib's header and the stored block's: row 0's filter byte
  const uLong crc = crc32(0, png.data() + type, static_cast<uInt>(length + 4));
  for (int i = 0; i < 4; ++i)
    png[type + 4 + length + i] = static_cast<unsigned char>(crc >> (24 - 8 * i));
  std::ofstream(dir / "filter.png", std::ios::binary)
      .write(reinterpret_cast<const char*>(png.data()), static_cast<std::streamsize>(png.size()));
  const std::string png_error = ErrorOf([&] { ReadDepthImage(dir / "filter.png", 5000.0); });
  EXPECT_NE(png_error.find("filter.png: corrupt PNG (its pixel data is damaged)"),
            std::string::npos)
      << png_error;
  EXPECT_EQ(png_error.find("adaptive"), std::string::npos) << png_error;

  cv::Mat color(120, 160, CV_8UC3);
  cv::randu(color, 0, 255);
  std::vector<unsigned char> jpeg;
  cv::imencode(".jpg", color, jpeg);
  jpeg.resize(jpeg.size() * 6 / 10);
  jpeg.insert(jpeg.end(), {0xFF, 0xD9});  // an end marker in the middle of the data
  std::ofstream(dir / "early.jpg", std::ios::binary)
      .write(reinterpret_cast<const char*>(jpeg.data()), static_cast<std::streamsize>(jpeg.size()));
  const std::string jpeg_error = ErrorOf([&] { ReadColorImage(dir / "early.jpg"); });
  EXPECT_NE(jpeg_error.find("early.jpg: corrupt JPEG ("), std::string::npos) << jpeg_error;
  EXPECT_EQ(jpeg_error.find("Premature"), std::string::npos) << jpeg_error;
  EXPECT_EQ(jpeg_error.find("Corrupt JPEG data"), std::string::npos) << jpeg_error;
}

// A full disk (/dev/full answers every write with ENOSPC) is said as such, for an image encoded
// by OpenCV and for a text output; the link to it is removed, never the device.
TEST(ImageIoTest, AFullDiskIsSaidAsSuch) {
  TempDir dir;
  std::filesystem::create_symlink("/dev/full", dir / "render.png");
  const std::string image_error =
      FailureOf([&] { WriteImage(dir / "render.png", cv::Mat(64, 64, CV_8UC3), ".png"); });
  EXPECT_NE(image_error.find("render.png: could not write the image: the disk is full"),
            std::string::npos)
      << image_error;
  EXPECT_TRUE(std::filesystem::exists("/dev/full"));
  std::filesystem::create_symlink("/dev/full", dir / "trajectory.txt");
  const Trajectory trajectory({{1.0, Eigen::Isometry3d::Identity()}});
  const std::string text_error = FailureOf([&] { trajectory.WriteTum(dir / "trajectory.txt"); });
  EXPECT_NE(text_error.find("could not write the trajectory: the disk is full"), std::string::npos)
      << text_error;
}

}  // namespace
}  // namespace stillmap
