// The place index against known truth: keyframes of random ORB-like descriptors, queried with
// noisy copies of one keyframe's (a true place), with descriptors of no keyframe (a new place)
// and with a blend (a place that shares a little with one keyframe).
#include "stillmap/tracking/place_index.h"

#include <gtest/gtest.h>

#include <map>
#include <random>

#include "stillmap/io/error.h"

namespace stillmap {
namespace {

cv::Mat RandomDescriptors(int rows, std::mt19937* generator) {
  cv::Mat out(rows, 32, CV_8U);
  std::uniform_int_distribution<int> byte(0, 255);
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < 32; ++c)
      out.at<std::uint8_t>(r, c) = static_cast<std::uint8_t>(byte(*generator));
  }
  return out;
}

// A copy with `bits` random bits of each descriptor flipped (a view of the same corners).
cv::Mat Flipped(const cv::Mat& descriptors, int bits, std::mt19937* generator) {
  cv::Mat out = descriptors.clone();
  std::uniform_int_distribution<int> position(0, 255);
  for (int r = 0; r < out.rows; ++r) {
    for (int b = 0; b < bits; ++b) {
      const int p = position(*generator);
      out.at<std::uint8_t>(r, p / 8) ^= static_cast<std::uint8_t>(1U << (p % 8));
    }
  }
  return out;
}

class PlaceIndexTest : public ::testing::Test {
 protected:
  void SetUp() override {
    for (int k = 0; k < 30; ++k) {
      keyframes_.push_back(RandomDescriptors(500, &generator_));
      index_.Add(k, keyframes_.back());
    }
  }
  std::mt19937 generator_{7};
  PlaceIndex index_{PlaceIndexOptions{}, 1};
  std::vector<cv::Mat> keyframes_;
};

TEST_F(PlaceIndexTest, FindsTheKeyframeOfASeenPlaceFirst) {
  for (int k : {0, 13, 29}) {
    // Half the corners seen again with 20 of 256 bits changed, half new.
    cv::Mat query = Flipped(keyframes_[static_cast<size_t>(k)].rowRange(0, 250), 20, &generator_);
    query.push_back(RandomDescriptors(250, &generator_));
    const auto candidates = index_.Query(query, 3, [](int) { return false; });
    ASSERT_FALSE(candidates.empty());
    EXPECT_EQ(candidates[0].keyframe_id, k);
    EXPECT_GT(candidates[0].votes, 100);  // most of the 250 seen again
    if (candidates.size() > 1) {
      EXPECT_LT(candidates[1].votes, 10);
    }
  }
}

TEST_F(PlaceIndexTest, ANewPlaceGetsNoStrongCandidate) {
  const auto candidates =
      index_.Query(RandomDescriptors(500, &generator_), 3, [](int) { return false; });
  for (const PlaceCandidate& candidate : candidates) EXPECT_LT(candidate.votes, 10);
}

TEST_F(PlaceIndexTest, SkipsAndForgetsKeyframes) {
  const cv::Mat query = Flipped(keyframes_[5], 10, &generator_);
  auto candidates = index_.Query(query, 3, [](int id) { return id == 5; });
  for (const PlaceCandidate& candidate : candidates) EXPECT_NE(candidate.keyframe_id, 5);
  for (int k = 0; k < 20; ++k) index_.Remove(k);  // past half the entries: compacted
  EXPECT_EQ(index_.keyframes(), 10U);
  EXPECT_EQ(index_.entries(), 10U * 500U);
  candidates = index_.Query(query, 3, [](int) { return false; });
  for (const PlaceCandidate& candidate : candidates) EXPECT_NE(candidate.keyframe_id, 5);
  const cv::Mat kept = Flipped(keyframes_[25], 10, &generator_);
  candidates = index_.Query(kept, 1, [](int) { return false; });
  ASSERT_FALSE(candidates.empty());
  EXPECT_EQ(candidates[0].keyframe_id, 25);
}

TEST_F(PlaceIndexTest, ACompactedIndexIsTheIndexOfWhatIsLeft) {
  // 16 of 30 keyframes removed: the 16th removal passes half the entries and compacts. The index
  // then holds what a new one given only keyframes 16-29 holds, to the byte.
  for (int k = 0; k < 16; ++k) index_.Remove(k);
  PlaceIndex fresh(PlaceIndexOptions{}, 1);
  for (size_t k = 16; k < keyframes_.size(); ++k) fresh.Add(static_cast<int>(k), keyframes_[k]);
  EXPECT_EQ(index_.entries(), fresh.entries());
  EXPECT_EQ(index_.MemoryBytes(), fresh.MemoryBytes());
  // A removal after the compaction takes that keyframe's entries and no other's.
  index_.Remove(20);
  EXPECT_EQ(index_.entries(), 13U * 500U);
  auto candidates =
      index_.Query(Flipped(keyframes_[20], 10, &generator_), 3, [](int) { return false; });
  for (const PlaceCandidate& candidate : candidates) EXPECT_NE(candidate.keyframe_id, 20);
  for (int k : {19, 21}) {
    candidates = index_.Query(Flipped(keyframes_[static_cast<size_t>(k)], 10, &generator_), 1,
                              [](int) { return false; });
    ASSERT_FALSE(candidates.empty());
    EXPECT_EQ(candidates[0].keyframe_id, k);
    EXPECT_GT(candidates[0].votes, 100);
  }
}

TEST_F(PlaceIndexTest, SameSeedSameAnswer) {
  PlaceIndex other(PlaceIndexOptions{}, 1);
  for (size_t k = 0; k < keyframes_.size(); ++k) other.Add(static_cast<int>(k), keyframes_[k]);
  const cv::Mat query = Flipped(keyframes_[3], 30, &generator_);
  const auto a = index_.Query(query, 5, [](int) { return false; });
  const auto b = other.Query(query, 5, [](int) { return false; });
  ASSERT_EQ(a.size(), b.size());
  for (size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].keyframe_id, b[i].keyframe_id);
    EXPECT_EQ(a[i].votes, b[i].votes);
  }
}

// With max_distance 0 a query descriptor votes exactly for the keyframes holding it (identical
// descriptors share every bucket), so the votes can be counted by brute force. Few key bits make
// buckets of many chunks; removals and a compaction come between the queries.
TEST(PlaceIndexExactTest, VotesAreTheKeyframesHoldingEachQueryDescriptor) {
  std::mt19937 generator(11);
  PlaceIndexOptions options;
  options.key_bits = 4;
  options.tables = 3;
  options.max_distance = 0;
  PlaceIndex index(options, 5);
  const cv::Mat pool = RandomDescriptors(400, &generator);
  std::uniform_int_distribution<int> row_of(0, pool.rows - 1);
  std::map<int, cv::Mat> keyframes;
  for (int k = 0; k < 60; ++k) {
    cv::Mat rows(90, 32, CV_8U);
    for (int r = 0; r < rows.rows; ++r) pool.row(row_of(generator)).copyTo(rows.row(r));
    keyframes[k] = rows;
    index.Add(k, rows);
  }
  const cv::Mat query = RandomDescriptors(40, &generator);
  for (int r = 0; r < 30; ++r) pool.row(row_of(generator)).copyTo(query.row(r));
  auto expect_brute_force_votes = [&] {
    std::map<int, int> truth;
    for (int q = 0; q < query.rows; ++q) {
      for (const auto& [k, rows] : keyframes) {
        for (int r = 0; r < rows.rows; ++r) {
          if (cv::norm(query.row(q), rows.row(r), cv::NORM_HAMMING) == 0.0) {
            ++truth[k];
            break;
          }
        }
      }
    }
    const auto candidates = index.Query(query, keyframes.size(), [](int) { return false; });
    std::map<int, int> votes;
    for (const PlaceCandidate& candidate : candidates)
      votes[candidate.keyframe_id] = candidate.votes;
    EXPECT_EQ(votes, truth);
  };
  expect_brute_force_votes();
  for (int k = 0; k < 60; ++k) {  // more than half the entries: the index compacts
    if (k % 2 == 1 && k != 1) continue;
    index.Remove(k);
    keyframes.erase(k);
  }
  expect_brute_force_votes();
  EXPECT_EQ(index.keyframes(), keyframes.size());
  EXPECT_EQ(index.entries(), keyframes.size() * 90);
}

TEST(PlaceIndexOptionsTest, RefusesImpossibleValues) {
  PlaceIndexOptions options;
  options.key_bits = 40;
  EXPECT_THROW(options.Validate(), InputError);
  options.key_bits = PlaceIndexOptions::kMaxKeyBits + 1;
  EXPECT_THROW(options.Validate(), InputError);
  options = {};
  options.tables = 0;
  EXPECT_THROW(PlaceIndex(options, 1), InputError);
}

}  // namespace
}  // namespace stillmap
