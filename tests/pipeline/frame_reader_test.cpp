#include "frame_reader.h"

#include <gtest/gtest.h>

#include <fstream>
#include <vector>

#include "stillmap/io/error.h"
#include "test_util.h"

namespace stillmap {
namespace {

constexpr size_t kFrames = 12;

// A plane seen by a camera sliding 1 cm per frame, written as a TUM folder.
void WriteSlidingSequence(const std::string& dir) {
  std::vector<Eigen::Isometry3d> poses(kFrames, Eigen::Isometry3d::Identity());
  for (size_t i = 0; i < poses.size(); ++i) poses[i].translation().x() = 0.01 * i;
  testing::WritePlaneSequence(dir, testing::SmallCamera(160, 120), {}, poses);
}

std::vector<size_t> AllFrames() {
  std::vector<size_t> indices(kFrames);
  for (size_t i = 0; i < kFrames; ++i) indices[i] = i;
  return indices;
}

FlowTracker Flow() { return FlowTracker(60, FlowCheckOptions{}); }

void ExpectSameMat(const cv::Mat& a, const cv::Mat& b, size_t k) {
  ASSERT_EQ(a.size(), b.size()) << "frame " << k;
  ASSERT_EQ(a.type(), b.type()) << "frame " << k;
  EXPECT_EQ(cv::norm(a, b, cv::NORM_INF), 0.0) << "frame " << k;
}

TEST(FrameReaderTest, ReadingAheadGivesTheFramesAndFlowOfReadingInPlace) {
  testing::TempDir dir;
  WriteSlidingSequence(dir.path());
  const Sequence sequence = Sequence::Open(dir.path(), testing::SmallCamera(160, 120));
  FrameReader ahead(sequence, AllFrames(), true, Flow());
  FrameReader in_place(sequence, AllFrames(), false, Flow());
  size_t tracked = 0;
  for (size_t k = 0; k < kFrames; ++k) {
    const PreparedFrame a = ahead.Get(k);
    const PreparedFrame b = in_place.Get(k);
    EXPECT_EQ(a.frame.index, k);
    EXPECT_EQ(b.frame.index, k);
    ExpectSameMat(a.frame.color, b.frame.color, k);
    ExpectSameMat(a.frame.depth_m, b.frame.depth_m, k);
    ExpectSameMat(a.gray, b.gray, k);
    ASSERT_TRUE(a.flow.has_value() && b.flow.has_value());
    EXPECT_EQ(a.flow->from, b.flow->from) << "frame " << k;
    EXPECT_EQ(a.flow->result.current, b.flow->result.current) << "frame " << k;
    EXPECT_EQ(a.flow->result.tracked, b.flow->result.tracked) << "frame " << k;
    for (std::uint8_t t : a.flow->result.tracked) tracked += t;
  }
  EXPECT_GT(tracked, 0u);  // the flow steps compared were not all empty
  EXPECT_EQ(ahead.flow_ms().size(), kFrames);
  EXPECT_EQ(ahead.checks().frames(), kFrames);
  EXPECT_EQ(in_place.checks().frames(), kFrames);
}

TEST(FrameReaderTest, ABadImageIsTheErrorOfItsFrameAndTheFramesBeforeItArrive) {
  testing::TempDir dir;
  WriteSlidingSequence(dir.path());
  const Sequence sequence = Sequence::Open(dir.path(), testing::SmallCamera(160, 120));
  const size_t bad = 7;
  std::ofstream(sequence.frames()[bad].color_path, std::ios::trunc) << "not a PNG";
  FrameReader reader(sequence, AllFrames(), true, Flow());
  for (size_t k = 0; k < bad; ++k) EXPECT_EQ(reader.Get(k).frame.index, k);
  EXPECT_THROW(reader.Get(bad), InputError);
}

TEST(FrameReaderTest, StopsReadingWhenTheCallerStopsEarly) {
  testing::TempDir dir;
  WriteSlidingSequence(dir.path());
  const Sequence sequence = Sequence::Open(dir.path(), testing::SmallCamera(160, 120));
  {
    FrameReader reader(sequence, AllFrames(), true, Flow());
    EXPECT_EQ(reader.Get(0).frame.index, 0u);
  }  // the destructor ends the reading thread after the frames queued (a hang fails by timeout)
  FrameReader reader(sequence, AllFrames(), true, std::nullopt);
  EXPECT_FALSE(reader.Get(0).flow.has_value());
}

}  // namespace
}  // namespace stillmap
