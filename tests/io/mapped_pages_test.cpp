#include "stillmap/io/mapped_pages.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <cstring>

#include "stillmap/io/cpu_usage.h"

namespace stillmap {
namespace {

constexpr std::size_t kMib = std::size_t{1} << 20;

struct Tagged {
  std::uint32_t tag = 7;
};

}  // namespace

TEST(MappedArrayTest, ValuesStartValueInitialisedAndMoveWithTheirPages) {
  MappedArray<std::uint32_t> zeros(100000);
  ASSERT_EQ(zeros.size(), 100000u);
  for (std::size_t i = 0; i < zeros.size(); ++i) ASSERT_EQ(zeros[i], 0u) << i;
  zeros[99999] = 5;
  MappedArray<std::uint32_t> moved(std::move(zeros));
  EXPECT_EQ(moved[99999], 5u);
  EXPECT_EQ(zeros.size(), 0u);  // NOLINT(bugprone-use-after-move): a moved-from array is empty
  EXPECT_EQ(zeros.data(), nullptr);
  MappedArray<Tagged> tagged(3);
  EXPECT_EQ(tagged[2].tag, 7u);  // a default member initialiser runs
  EXPECT_EQ(MappedArray<int>(0).data(), nullptr);
}

// Freed, the pages leave the process at once: no allocator keeps them.
TEST(MappedArrayTest, FreedPagesLeaveTheResidentMemory) {
  const double before = ResidentMemoryMib();
  {
    MappedArray<char> block(256 * kMib);
    std::memset(block.data(), 1, block.size());
    EXPECT_GT(ResidentMemoryMib() - before, 250.0);
    block = MappedArray<char>();
    EXPECT_LT(ResidentMemoryMib() - before, 10.0);
    EXPECT_EQ(block.size(), 0u);
    MappedArray<char> again(64 * kMib);
    std::memset(again.data(), 1, again.size());
  }
  EXPECT_LT(ResidentMemoryMib() - before, 10.0);
}

// Values pushed across many pages read back as pushed; cleared, the pages leave the process.
TEST(PagedArrayTest, KeepsItsValuesAcrossPagesAndHandsThemBackCleared) {
  const double before = ResidentMemoryMib();
  PagedArray<std::uint64_t, 10> values;       // 8 KiB pages
  constexpr std::uint64_t kCount = 8 * kMib;  // 64 MiB
  for (std::uint64_t i = 0; i < kCount; ++i) values.push_back(i * 3 + 1);
  ASSERT_EQ(values.size(), kCount);
  for (std::uint64_t i = 0; i < kCount; i += 997) ASSERT_EQ(values[i], i * 3 + 1) << i;
  EXPECT_EQ(values[kCount - 1], (kCount - 1) * 3 + 1);
  EXPECT_GE(values.MemoryBytes(), kCount * sizeof(std::uint64_t));
  EXPECT_GT(ResidentMemoryMib() - before, 60.0);
  PagedArray<std::uint64_t, 10> moved = std::move(values);
  EXPECT_EQ(moved[12345], 12345u * 3 + 1);
  moved.clear();
  EXPECT_EQ(moved.size(), 0u);
  EXPECT_LT(ResidentMemoryMib() - before, 10.0);
  moved.push_back(9);
  EXPECT_EQ(moved[0], 9u);
}

}  // namespace stillmap
