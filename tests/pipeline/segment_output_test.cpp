// What a build tells the user of a map segment written apart: where it went, its span, and
// whether a map (and a later merge) can be made of it.
#include "segment_output.h"

#include <gtest/gtest.h>

namespace stillmap {
namespace {

SegmentSummary TwoFramesLostAgain() {
  SegmentSummary summary;
  summary.id = 5;
  summary.first_time = 1298.333333;
  summary.last_time = 1298.366667;
  summary.frames = 2;
  summary.keyframes = 2;
  return summary;
}

bool Has(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

TEST(SegmentOutputTest, ANewMapLostAgainNamesItsSpanAndCountsItsFramesAsLost) {
  const std::string warning = LostAgainWarning(TwoFramesLostAgain());
  EXPECT_TRUE(Has(warning, "began anew at 1298.33 s")) << warning;
  EXPECT_TRUE(Has(warning, "lost again at 1298.37 s (2 frames)")) << warning;
  EXPECT_TRUE(Has(warning, "before any of its 2 keyframe(s) was kept for a map")) << warning;
  EXPECT_TRUE(Has(warning, "its frames count as lost")) << warning;
  EXPECT_FALSE(Has(warning, "segments/")) << warning;
}

TEST(SegmentOutputTest, ASegmentApartCanBeMergedAndNamesWhyItHasNoMap) {
  const std::string mapped = ApartSegmentWarning(TwoFramesLostAgain(), "", "OUT/segments/5");
  EXPECT_TRUE(Has(mapped, "1298.33 - 1298.37 s, 2 frames")) << mapped;
  EXPECT_TRUE(Has(mapped, "written apart in OUT/segments/5/")) << mapped;
  EXPECT_TRUE(Has(mapped, "'stillmap merge' can join it with this build's session.bin")) << mapped;
  EXPECT_FALSE(Has(mapped, "holds no map")) << mapped;
  const std::string unmapped =
      ApartSegmentWarning(TwoFramesLostAgain(), "the map is empty", "OUT/segments/5");
  EXPECT_TRUE(Has(unmapped, "it holds no map, only its poses: the map is empty")) << unmapped;
}

}  // namespace
}  // namespace stillmap
