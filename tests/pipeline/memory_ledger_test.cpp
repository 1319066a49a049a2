#include "memory_ledger.h"

#include <gtest/gtest.h>

#include <chrono>
#include <cstring>
#include <thread>
#include <vector>

#include "stillmap/io/cpu_usage.h"

namespace stillmap {
namespace {

constexpr size_t kMib = size_t{1024} * 1024;

// Holds `mib` MiB resident (every page written) for `hold_ms`, under `phase`, and samples the
// ledger meanwhile with `owners`.
void HoldWhileSampling(MemoryLedger& ledger, size_t mib, const std::string& phase,
                       const std::vector<std::pair<std::string, size_t>>& owners) {
  ledger.Phase(phase);  // first: the watcher may read while the pages are written
  std::vector<char> block(mib * kMib);
  std::memset(block.data(), 1, block.size());
  ledger.Sample(phase, owners);
  std::this_thread::sleep_for(std::chrono::milliseconds(300));  // the watcher reads every 50 ms
  EXPECT_EQ(block[block.size() / 2], 1);
}

TEST(MemoryLedgerTest, TheHighestSampleIsBrokenDownWithEachOwnersLargest) {
  MemoryLedger ledger;
  ledger.AddFixed("models", 5.0);
  ledger.Sample("small", {{"cloud", 10 * kMib}, {"index", 30 * kMib}});
  HoldWhileSampling(ledger, 400, "big", {{"cloud", 400 * kMib}, {"index", 1 * kMib}});
  ledger.Phase("after");
  ledger.Sample("after", {{"cloud", 2 * kMib}, {"index", 3 * kMib}});
  const MemoryFigures figures = ledger.Finish();

  EXPECT_EQ(figures.samples, 3u);
  EXPECT_EQ(figures.peak_when, "big");
  ASSERT_EQ(figures.at_peak.size(), 3u);
  EXPECT_EQ(figures.at_peak[0].name, "cloud");  // largest first
  EXPECT_DOUBLE_EQ(figures.at_peak[0].mib, 400.0);
  EXPECT_EQ(figures.at_peak[1].name, "models");
  EXPECT_DOUBLE_EQ(figures.at_peak[1].mib, 5.0);
  EXPECT_DOUBLE_EQ(figures.at_peak[2].mib, 1.0);
  // The sample's resident memory holds the 400 MiB block.
  EXPECT_GT(figures.peak_sample_mib, 400.0);
  // Each owner's largest comes from whichever sample had it.
  ASSERT_EQ(figures.largest.size(), 3u);
  for (const MemoryOwner& owner : figures.largest) {
    const double expected = owner.name == "cloud" ? 400.0 : owner.name == "index" ? 30.0 : 5.0;
    EXPECT_DOUBLE_EQ(owner.mib, expected) << owner.name;
  }
  // The highest reading holds the sample's (a sample is a reading too), in its phase.
  EXPECT_GE(figures.peak_watched_mib, figures.peak_sample_mib);
  EXPECT_EQ(figures.peak_watched_phase, "big");
}

TEST(MemoryLedgerTest, ADroppedFixedOwnerIsLeftOutOfLaterSamples) {
  MemoryLedger ledger;
  ledger.AddFixed("models", 5.0);
  ledger.AddFixed("tables", 2.0);
  ledger.Sample("with the models", {{"cloud", 1 * kMib}});
  ledger.DropFixed("models");
  HoldWhileSampling(ledger, 200, "without", {{"cloud", 200 * kMib}});
  const MemoryFigures figures = ledger.Finish();

  ASSERT_EQ(figures.peak_when, "without");
  ASSERT_EQ(figures.at_peak.size(), 2u);
  EXPECT_EQ(figures.at_peak[0].name, "cloud");
  EXPECT_EQ(figures.at_peak[1].name, "tables");
  // Its largest, from the sample before, stays.
  ASSERT_EQ(figures.largest.size(), 3u);
  EXPECT_EQ(figures.largest[2].name, "tables");
  EXPECT_DOUBLE_EQ(figures.largest[1].mib, 5.0);
}

TEST(MemoryLedgerTest, ResidentMemoryGrowsWithPagesWritten) {
  const double before = ResidentMemoryMib();
  std::vector<char> block(200 * kMib);
  std::memset(block.data(), 1, block.size());
  const double after = ResidentMemoryMib();
  EXPECT_EQ(block[block.size() - 1], 1);
  EXPECT_GT(after - before, 190.0);
}

}  // namespace
}  // namespace stillmap
