// RVL depth (compressed_depth_image_transport's "compressedDepth rvl"): a stream worked out by hand
// from Wilson's paper decodes to its pixels; a real depth image encoded here (the paper's encoder,
// written out in the test) decodes to itself and, through DepthFromRosCompressed, to its metres;
// damaged streams are refused.
#include "bag/rvl.h"

#include <gtest/gtest.h>

#include <cstring>
#include <fstream>
#include <opencv2/imgcodecs.hpp>

#include "bag/ros_messages.h"
#include "stillmap/io/error.h"
#include "test_util.h"

namespace stillmap {
namespace {

// Wilson's encoder: runs of zeros and of non-zeros, each value as the zigzag of its difference to
// the previous non-zero, in 3-bit groups of nibbles packed into 32-bit words from the high end.
class RvlWriter {
 public:
  std::vector<std::uint8_t> Encode(const std::vector<std::uint16_t>& pixels) {
    size_t at = 0;
    int previous = 0;
    while (at < pixels.size()) {
      size_t zeros = 0, values = 0;
      while (at + zeros < pixels.size() && pixels[at + zeros] == 0) ++zeros;
      Put(zeros);
      at += zeros;
      while (at + values < pixels.size() && pixels[at + values] != 0) ++values;
      Put(values);
      for (size_t i = 0; i < values; ++i, ++at) {
        const int delta = pixels[at] - previous;
        // Zigzag: 2 |d| for d >= 0, 2 |d| - 1 for d < 0 (no shift of a negative value).
        Put(delta >= 0 ? 2U * static_cast<std::uint32_t>(delta)
                       : 2U * static_cast<std::uint32_t>(-delta) - 1U);
        previous = pixels[at];
      }
    }
    if (nibbles_ > 0) Flush(word_ << (4U * (8U - nibbles_)));
    return bytes_;
  }

 private:
  void Put(std::uint32_t value) {
    do {
      std::uint32_t nibble = value & 0x7U;
      value >>= 3U;
      if (value != 0) nibble |= 0x8U;
      word_ = (word_ << 4U) | nibble;
      if (++nibbles_ == 8) {
        Flush(word_);
        nibbles_ = 0;
        word_ = 0;
      }
    } while (value != 0);
  }
  void Flush(std::uint32_t word) {
    for (int i = 0; i < 4; ++i) bytes_.push_back(static_cast<std::uint8_t>(word >> (8 * i)));
  }
  std::vector<std::uint8_t> bytes_;
  std::uint32_t word_ = 0;
  unsigned nibbles_ = 0;
};

TEST(RvlTest, AStreamWorkedOutByHandDecodes) {
  // Two zeros, two values: 5 (zigzag 10 = groups 2, 1) and 6 (+1, zigzag 2). Nibbles 2 2 A 1 2,
  // from the word's high end: 0x22A12000, stored little-endian.
  const std::vector<std::uint8_t> stream = {0x00, 0x20, 0xA1, 0x22};
  std::vector<std::uint16_t> pixels(4, 99);
  ASSERT_TRUE(DecodeRvl(stream.data(), stream.size(), pixels.data(), pixels.size()));
  EXPECT_EQ(pixels, (std::vector<std::uint16_t>{0, 0, 5, 6}));
  std::vector<std::uint16_t> more(5);
  EXPECT_FALSE(DecodeRvl(stream.data(), stream.size(), more.data(), more.size()));  // ends early
  std::vector<std::uint16_t> fewer(3);
  EXPECT_FALSE(DecodeRvl(stream.data(), stream.size(), fewer.data(), fewer.size()));  // runs past
}

TEST(RvlTest, ARealDepthImageRoundTripsAndGivesItsMetres) {
  const std::optional<std::string> sequence = testing::SharedSequence("tum_fr3_teddy_200");
  if (!sequence) GTEST_SKIP() << "tum_fr3_teddy_200 not in ../shared/data";
  std::ifstream list(*sequence + "/depth.txt");
  std::string line;
  while (std::getline(list, line) && (line.empty() || line[0] == '#')) {
  }
  const cv::Mat depth =
      cv::imread(*sequence + "/" + line.substr(line.find(' ') + 1), cv::IMREAD_UNCHANGED);
  ASSERT_EQ(depth.type(), CV_16UC1);
  cv::Mat millimetres;
  depth.convertTo(millimetres, CV_16U, 1.0 / 5.0);  // TUM's 5000 per metre as ROS's 1000
  const std::vector<std::uint16_t> pixels(millimetres.begin<std::uint16_t>(),
                                          millimetres.end<std::uint16_t>());
  const std::vector<std::uint8_t> rvl = RvlWriter().Encode(pixels);
  EXPECT_LT(rvl.size(), pixels.size() * 2);
  std::vector<std::uint16_t> decoded(pixels.size());
  ASSERT_TRUE(DecodeRvl(rvl.data(), rvl.size(), decoded.data(), decoded.size()));
  EXPECT_EQ(decoded, pixels);
  // As compressed_depth_image_transport sends it: ConfigHeader, columns, rows, RVL.
  std::vector<std::uint8_t> data(12, 0);
  for (const std::uint32_t side : {static_cast<std::uint32_t>(millimetres.cols),
                                   static_cast<std::uint32_t>(millimetres.rows)}) {
    for (int i = 0; i < 4; ++i) data.push_back(static_cast<std::uint8_t>(side >> (8 * i)));
  }
  data.insert(data.end(), rvl.begin(), rvl.end());
  RosCompressedImage image;
  image.format = "16UC1; compressedDepth rvl";
  image.data = data.data();
  image.size = data.size();
  cv::Mat expected;
  millimetres.convertTo(expected, CV_32F, 0.001);
  EXPECT_EQ(cv::norm(DepthFromRosCompressed(image, 0.001, "test"), expected, cv::NORM_INF), 0.0);
  image.size = data.size() - 40;  // cut short
  EXPECT_THROW(DepthFromRosCompressed(image, 0.001, "test"), InputError);
  data[12] = 0xFF;  // columns claimed far beyond the data
  data[13] = 0xFF;
  image.size = data.size();
  EXPECT_THROW(DepthFromRosCompressed(image, 0.001, "test"), InputError);
}

}  // namespace
}  // namespace stillmap
