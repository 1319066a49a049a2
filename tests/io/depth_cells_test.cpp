#include "stillmap/io/depth_cells.h"

#include <gtest/gtest.h>

#include <limits>

namespace stillmap {
namespace {

// A 20 x 12 image in cells of 8 px: 3 x 2 cells, the last column and row reaching past it.
TEST(DepthCellsTest, EachCellHoldsItsNearestFarthestMeanAndShare) {
  cv::Mat depth(12, 20, CV_32FC1, cv::Scalar(2.0f));
  depth(cv::Rect(0, 0, 4, 8)).setTo(1.0f);  // half of cell (0, 0) at 1 m
  depth.at<float>(0, 8) = 9.0f;             // beyond max_depth: not read
  depth.at<float>(1, 8) = 0.0f;             // no reading
  depth.at<float>(2, 8) = std::numeric_limits<float>::quiet_NaN();
  cv::Mat mask(12, 20, CV_8UC1, cv::Scalar(0));
  mask(cv::Rect(8, 4, 8, 4)).setTo(255);  // half of cell (0, 1) masked
  const cv::Mat cells = DepthCells(depth, mask, 8, 0.1, 4.0);
  ASSERT_EQ(cells.size(), cv::Size(3, 2));
  ASSERT_EQ(cells.type(), CV_32FC4);
  const cv::Vec4f first = cells.at<cv::Vec4f>(0, 0);
  EXPECT_FLOAT_EQ(first[0], 1.0f);
  EXPECT_FLOAT_EQ(first[1], 2.0f);
  EXPECT_FLOAT_EQ(first[2], 1.5f);
  EXPECT_FLOAT_EQ(first[3], 1.0f);
  EXPECT_FLOAT_EQ(cells.at<cv::Vec4f>(0, 1)[3], (32.0f - 3.0f) / 64.0f);
  EXPECT_FLOAT_EQ(cells.at<cv::Vec4f>(0, 2)[3], 4.0f * 8.0f / 64.0f);  // 4 columns in the image
  EXPECT_FLOAT_EQ(cells.at<cv::Vec4f>(1, 2)[3], 4.0f * 4.0f / 64.0f);
  EXPECT_FLOAT_EQ(cells.at<cv::Vec4f>(1, 2)[2], 2.0f);
}

TEST(DepthCellsTest, ACellWithNothingReadIsZero) {
  cv::Mat depth(8, 8, CV_32FC1, cv::Scalar(0.05f));  // all nearer than min_depth
  const cv::Mat cells = DepthCells(depth, cv::Mat(), 8, 0.1, 4.0);
  EXPECT_EQ(cells.at<cv::Vec4f>(0, 0), cv::Vec4f(0.0f, 0.0f, 0.0f, 0.0f));
}

}  // namespace
}  // namespace stillmap
