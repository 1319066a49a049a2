#include "memory_ledger.h"

#include <gtest/gtest.h>
#include <sys/mman.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "stillmap/io/cpu_usage.h"
#include "test_util.h"

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

// The owner named `name` in `owners` (a failed expectation and 0 MiB when there is none).
MemoryOwner Named(const std::vector<MemoryOwner>& owners, const std::string& name) {
  const auto it = std::find_if(owners.begin(), owners.end(),
                               [&](const MemoryOwner& owner) { return owner.name == name; });
  EXPECT_NE(it, owners.end()) << name;
  return it == owners.end() ? MemoryOwner{name, 0.0} : *it;
}

// /proc/self/status's resident file-backed and shared-memory pages [MiB]: the kernel's other
// account of what FileBackedMemoryMib reads from statm.
double StatusFileAndSharedMib() {
  std::ifstream status("/proc/self/status");
  double kib = 0.0;
  for (std::string line; std::getline(status, line);) {
    std::istringstream fields(line);
    std::string key;
    double value = 0.0;
    if (fields >> key >> value && (key == "RssFile:" || key == "RssShmem:")) kib += value;
  }
  return kib / 1024.0;
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
  // The owners given, the fixed one and the program's code and libraries, largest first.
  ASSERT_EQ(figures.at_peak.size(), 4u);
  EXPECT_EQ(figures.at_peak[0].name, "cloud");
  EXPECT_DOUBLE_EQ(figures.at_peak[0].mib, 400.0);
  EXPECT_DOUBLE_EQ(Named(figures.at_peak, "models").mib, 5.0);
  EXPECT_DOUBLE_EQ(Named(figures.at_peak, "index").mib, 1.0);
  EXPECT_TRUE(
      std::is_sorted(figures.at_peak.begin(), figures.at_peak.end(),
                     [](const MemoryOwner& a, const MemoryOwner& b) { return a.mib > b.mib; }));
  // The sample's resident memory holds the 400 MiB block and the code beside it.
  const double code_mib = Named(figures.at_peak, kCodeMemoryOwner).mib;
  EXPECT_GT(code_mib, 1.0);
  EXPECT_GT(figures.peak_sample_mib, 400.0 + code_mib);
  // Each owner's largest comes from whichever sample had it.
  ASSERT_EQ(figures.largest.size(), 4u);
  EXPECT_DOUBLE_EQ(Named(figures.largest, "cloud").mib, 400.0);
  EXPECT_DOUBLE_EQ(Named(figures.largest, "index").mib, 30.0);
  EXPECT_DOUBLE_EQ(Named(figures.largest, "models").mib, 5.0);
  EXPECT_GE(Named(figures.largest, kCodeMemoryOwner).mib, code_mib);
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
  ASSERT_EQ(figures.at_peak.size(), 3u);
  EXPECT_EQ(figures.at_peak[0].name, "cloud");
  EXPECT_DOUBLE_EQ(Named(figures.at_peak, "tables").mib, 2.0);
  Named(figures.at_peak, kCodeMemoryOwner);
  for (const MemoryOwner& owner : figures.at_peak) EXPECT_NE(owner.name, "models");
  // Its largest, from the sample before, stays.
  ASSERT_EQ(figures.largest.size(), 4u);
  EXPECT_DOUBLE_EQ(Named(figures.largest, "models").mib, 5.0);
}

TEST(MemoryLedgerTest, ResidentMemoryGrowsWithPagesWritten) {
  const double before = ResidentMemoryMib();
  std::vector<char> block(200 * kMib);
  std::memset(block.data(), 1, block.size());
  const double after = ResidentMemoryMib();
  EXPECT_EQ(block[block.size() - 1], 1);
  EXPECT_GT(after - before, 190.0);
}

TEST(MemoryLedgerTest, FileBackedMemoryGrowsWithAMappedFilesPagesNotWithAllocatedOnes) {
  // The kernel's two accounts agree (read a moment apart: within a few pages).
  EXPECT_NEAR(FileBackedMemoryMib(), StatusFileAndSharedMib(), 1.0);

  testing::TempDir dir;
  const std::string path = dir / "pages.bin";
  constexpr size_t kFileBytes = 64 * kMib;
  {
    std::ofstream file(path, std::ios::binary);
    const std::vector<char> chunk(kMib, 7);
    for (size_t written = 0; written < kFileBytes; written += chunk.size()) {
      file.write(chunk.data(), static_cast<std::streamsize>(chunk.size()));
    }
    ASSERT_TRUE(file.good());
  }
  const double before = FileBackedMemoryMib();
  std::FILE* file = std::fopen(path.c_str(), "rb");
  ASSERT_NE(file, nullptr);
  void* mapped = mmap(nullptr, kFileBytes, PROT_READ, MAP_PRIVATE, fileno(file), 0);
  std::fclose(file);
  ASSERT_NE(mapped, MAP_FAILED);
  const auto* bytes = static_cast<const volatile char*>(mapped);
  int sum = 0;
  for (size_t at = 0; at < kFileBytes; at += 4096) sum += bytes[at];  // every page read in
  EXPECT_EQ(sum, 7 * static_cast<int>(kFileBytes / 4096));
  const double with_file = FileBackedMemoryMib();
  EXPECT_GT(with_file - before, 60.0);
  EXPECT_NEAR(with_file, StatusFileAndSharedMib(), 1.0);

  std::vector<char> block(100 * kMib);
  std::memset(block.data(), 1, block.size());
  EXPECT_LT(std::abs(FileBackedMemoryMib() - with_file), 4.0);  // anonymous pages are not files'
  EXPECT_EQ(block[block.size() - 1], 1);
  munmap(mapped, kFileBytes);
  EXPECT_LT(FileBackedMemoryMib(), with_file - 60.0);
}

}  // namespace
}  // namespace stillmap
