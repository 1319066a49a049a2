#include "stillmap/mapping/keyframe_selection.h"

#include <gtest/gtest.h>

#include <numeric>

#include "stillmap/io/error.h"

namespace stillmap {
namespace {

std::vector<int> Ids(int first, int count) {
  std::vector<int> ids(static_cast<size_t>(count));
  std::iota(ids.begin(), ids.end(), first);
  return ids;
}

TEST(KeyframeSelectionTest, AFrameMaskedBeyondTheShareIsInvalidWhateverItsLandmarks) {
  KeyframeSelector selector(KeyframeSelectionOptions{});  // paper 000: more than half masked
  EXPECT_EQ(selector.Judge(0.51, Ids(0, 100)), KeyframeVerdict::kInvalid);
  EXPECT_EQ(selector.Judge(0.50, Ids(0, 100)), KeyframeVerdict::kFused);
  EXPECT_EQ(selector.invalid(), 1u);
  EXPECT_EQ(selector.fused(), 1u);
}

TEST(KeyframeSelectionTest, RedundantOnlyWhenMoreThanTheShareOfItsLandmarksWasSelected) {
  KeyframeSelectionOptions options;
  options.max_shared_landmarks = 0.5;  // the paper's value, easy to count
  KeyframeSelector selector(options);
  ASSERT_EQ(selector.Judge(0.0, Ids(0, 100)), KeyframeVerdict::kFused);
  // 50 of 100 shared: not more than half, fused.
  EXPECT_EQ(selector.Judge(0.0, Ids(50, 100)), KeyframeVerdict::kFused);
  // Now 0..149 are selected: 51 of 100 shared.
  EXPECT_EQ(selector.Judge(0.0, Ids(99, 100)), KeyframeVerdict::kRedundant);
  EXPECT_EQ(selector.redundant(), 1u);
}

TEST(KeyframeSelectionTest, RejectedKeyframesLandmarksDoNotCount) {
  KeyframeSelectionOptions options;
  options.max_shared_landmarks = 0.5;
  KeyframeSelector selector(options);
  ASSERT_EQ(selector.Judge(0.9, Ids(0, 100)), KeyframeVerdict::kInvalid);
  // The invalid keyframe's landmarks were not selected, so this one shares none.
  EXPECT_EQ(selector.Judge(0.0, Ids(0, 100)), KeyframeVerdict::kFused);
}

TEST(KeyframeSelectionTest, WithoutLandmarksAValidFrameIsFused) {
  KeyframeSelector selector(KeyframeSelectionOptions{});
  EXPECT_EQ(selector.Judge(0.0, {}), KeyframeVerdict::kFused);
  EXPECT_EQ(selector.Judge(0.0, {}), KeyframeVerdict::kFused);
}

TEST(KeyframeSelectionTest, DisabledFusesEverything) {
  KeyframeSelectionOptions options;
  options.enabled = false;
  KeyframeSelector selector(options);
  EXPECT_EQ(selector.Judge(1.0, Ids(0, 10)), KeyframeVerdict::kFused);
  EXPECT_EQ(selector.Judge(1.0, Ids(0, 10)), KeyframeVerdict::kFused);
  EXPECT_EQ(selector.fused(), 2u);
  EXPECT_EQ(options.Describe(), "off: every tracking keyframe is fused");
}

TEST(KeyframeSelectionTest, ImpossibleSharesAreRefusedByKey) {
  for (double share : {0.0, -0.1, 1.5}) {
    KeyframeSelectionOptions masked;
    masked.max_masked_share = share;
    EXPECT_THROW(masked.Validate(), InputError) << share;
    KeyframeSelectionOptions shared;
    shared.max_shared_landmarks = share;
    try {
      shared.Validate();
      ADD_FAILURE() << share << " accepted";
    } catch (const InputError& e) {
      // Its own key: no configuration registered the keys.
      EXPECT_NE(std::string(e.what()).find("max_shared_landmarks"), std::string::npos);
    }
  }
}

}  // namespace
}  // namespace stillmap
