// The inlined Hamming distance against OpenCV's NORM_HAMMING on random descriptors.
#include "hamming.h"

#include <gtest/gtest.h>

#include <cstring>
#include <opencv2/core.hpp>

namespace stillmap {
namespace {

TEST(HammingTest, MatchesOpenCvOnRandomDescriptors) {
  cv::RNG rng(7);
  cv::Mat a(1, 32, CV_8UC1), b(1, 32, CV_8UC1);
  for (int trial = 0; trial < 2000; ++trial) {
    rng.fill(a, cv::RNG::UNIFORM, 0, 256);
    rng.fill(b, cv::RNG::UNIFORM, 0, 256);
    if (trial % 100 == 0) a.setTo(0xFF), b.setTo(0);  // every bit differs: 256
    Descriptor da, db;
    std::memcpy(da.data(), a.data, sizeof(da));
    std::memcpy(db.data(), b.data, sizeof(db));
    const int expected = static_cast<int>(cv::norm(a, b, cv::NORM_HAMMING));
    ASSERT_EQ(HammingDistance(da, db), expected) << "trial " << trial;
    ASSERT_EQ(HammingDistance(da, da), 0);
  }
}

TEST(HammingTest, PopCountOfSingleWords) {
  EXPECT_EQ(PopCount64(0), 0);
  EXPECT_EQ(PopCount64(~0ULL), 64);
  EXPECT_EQ(PopCount64(0x8000000000000001ULL), 2);
  for (int bit = 0; bit < 64; ++bit) EXPECT_EQ(PopCount64(1ULL << bit), 1);
}

}  // namespace
}  // namespace stillmap
