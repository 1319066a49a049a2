#include "stillmap/io/image_regions.h"

#include <gtest/gtest.h>

namespace stillmap {
namespace {

// A 40 x 30 mask: a 10 x 10 square (100 px, value 255), a 3 x 3 speck (9 px, value 7), and two
// pixels touching only at a corner with a 4 x 4 block (17 px: one region, 8-connected).
cv::Mat Regions() {
  cv::Mat mask(30, 40, CV_8UC1, cv::Scalar(0));
  mask(cv::Rect(2, 2, 10, 10)).setTo(255);
  mask(cv::Rect(30, 3, 3, 3)).setTo(7);
  mask(cv::Rect(20, 20, 4, 4)).setTo(255);
  mask.at<std::uint8_t>(24, 24) = 255;  // the block's corner's diagonal neighbour
  return mask;
}

TEST(ImageRegionsTest, RegionsBelowTheSizeAreClearedAndTheOthersKeepTheirValues) {
  cv::Mat mask = Regions();
  EXPECT_TRUE(DropSmallRegions(10, &mask));
  EXPECT_EQ(cv::countNonZero(mask(cv::Rect(30, 3, 3, 3))), 0);  // the speck
  EXPECT_EQ(cv::countNonZero(mask(cv::Rect(2, 2, 10, 10))), 100);
  EXPECT_EQ(mask.at<std::uint8_t>(5, 5), 255);
  EXPECT_EQ(cv::countNonZero(mask), 100 + 17);  // the block and its diagonal pixel: one region
  // 18 px: the 17-px region goes too.
  EXPECT_TRUE(DropSmallRegions(18, &mask));
  EXPECT_EQ(cv::countNonZero(mask), 100);
  // 101 px: nothing is left, and it says so.
  EXPECT_FALSE(DropSmallRegions(101, &mask));
  EXPECT_EQ(cv::countNonZero(mask), 0);
  EXPECT_FALSE(DropSmallRegions(0, &mask));  // an empty mask, not counted by size
}

TEST(ImageRegionsTest, NothingIsClearedAtSizeZeroOrWhenEveryRegionIsLargeEnough) {
  const cv::Mat original = Regions();
  for (const int size : {0, -3, 9}) {
    cv::Mat mask = original.clone();
    EXPECT_TRUE(DropSmallRegions(size, &mask)) << size;
    EXPECT_EQ(cv::countNonZero(mask != original), 0) << size;
  }
}

}  // namespace
}  // namespace stillmap
