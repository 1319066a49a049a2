#include "stream_checks.h"

#include <gtest/gtest.h>

namespace stillmap {
namespace {

Frame FrameOfColour(int value) {
  Frame frame;
  frame.color = cv::Mat(4, 4, CV_8UC3, cv::Scalar::all(value));
  frame.depth_m = cv::Mat(4, 4, CV_32FC1, cv::Scalar(2.0));
  return frame;
}

TEST(StreamChecksTest, AFrozenColourStreamIsCountedAndWarnedOf) {
  StreamChecks checks;
  for (int k = 0; k < 4; ++k) checks.Add(FrameOfColour(7));
  EXPECT_EQ(checks.frames(), 4u);
  EXPECT_EQ(checks.frozen_colour_frames(), 3u);
  ASSERT_EQ(checks.Warnings(5000.0).size(), 1u);
  EXPECT_NE(checks.Warnings(5000.0)[0].find("3 of 4 colour frames"), std::string::npos);
}

}  // namespace
}  // namespace stillmap
