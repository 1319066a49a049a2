// Damaged records in copies of the shared ROS 1 (lz4 chunks) and MCAP (zstd chunks) bags cost
// only themselves (issue 49): the messages read from a copy with one chunk damaged are exactly
// the intact bag's messages less those of that chunk, whether the chunk's header, its length or
// its data is hit, and a topic whose connection or channel record was in the damaged chunk is
// recovered from the bag's index or summary.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <set>

#include "bag/bytes.h"
#include "bag_test_util.h"
#include "stillmap/io/sequence.h"
#include "test_util.h"

namespace stillmap {
namespace {

namespace fs = std::filesystem;

// A message by what identifies it: topic, record time and size.
using MessageKey = std::tuple<std::string, double, size_t>;

struct Contents {
  std::multiset<MessageKey> messages;
  std::map<std::uint64_t, std::multiset<MessageKey>> by_block;  // by chunk offset
  std::vector<std::string> warnings;
  bool truncated = false;
};

Contents Read(const std::string& path) {
  const std::unique_ptr<BagReader> bag = OpenBag(path);
  Contents contents;
  bag->Scan([&](const BagMessage& message) {
    const MessageKey key{bag->topics().at(message.topic).name, message.time, message.size};
    contents.messages.insert(key);
    contents.by_block[message.position.block].insert(key);
  });
  contents.warnings = bag->warnings();
  contents.truncated = bag->truncated();
  return contents;
}

std::vector<char> Bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

std::string Write(const testing::TempDir& dir, const std::string& name,
                  const std::vector<char>& bytes) {
  const std::string path = dir / name;
  std::ofstream(path, std::ios::binary)
      .write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  return path;
}

std::multiset<MessageKey> Without(const Contents& intact, std::uint64_t block) {
  std::multiset<MessageKey> kept = intact.messages;
  for (const MessageKey& key : intact.by_block.at(block)) kept.erase(kept.find(key));
  return kept;
}

std::string Listed(const std::vector<std::string>& lines) {
  std::string text;
  for (const std::string& line : lines) text += line + "\n";
  return text;
}

// The chunks' offsets in file order (blocks of the intact scan).
std::vector<std::uint64_t> Chunks(const Contents& intact) {
  std::vector<std::uint64_t> chunks;
  for (const auto& entry : intact.by_block) chunks.push_back(entry.first);
  return chunks;
}

// Where a ROS 1 record's data starts: after its header length, header and data length.
std::uint64_t Ros1DataStart(const std::vector<char>& bag, std::uint64_t record) {
  return record + 4 + Le32(reinterpret_cast<const std::uint8_t*>(bag.data() + record)) + 4;
}

// Each damage applied to one chunk of `name` (chosen by `pick` among the chunks).
void ExpectOnlyTheChunkLost(
    const std::string& name, size_t pick_numerator,
    const std::vector<
        std::pair<std::string, std::function<void(std::vector<char>*, std::uint64_t)>>>& damages) {
  const std::optional<std::string> source = testing::SharedBag(name);
  if (!source) GTEST_SKIP() << "bags/" << name << " not in ../shared/data";
  const Contents intact = Read(*source);
  ASSERT_TRUE(intact.warnings.empty()) << Listed(intact.warnings);
  const std::vector<std::uint64_t> chunks = Chunks(intact);
  ASSERT_GE(chunks.size(), 4u);
  const std::uint64_t chunk = chunks[chunks.size() * pick_numerator / 4];
  testing::TempDir dir;
  for (const auto& [what, damage] : damages) {
    std::vector<char> bytes = Bytes(*source);
    damage(&bytes, chunk);
    const std::string path = Write(dir, "damaged_" + fs::path(name).filename().string(), bytes);
    const Contents damaged = Read(path);
    EXPECT_EQ(damaged.messages, Without(intact, chunk))
        << what << " at the chunk at byte " << chunk << ": " << damaged.messages.size()
        << " messages read, intact " << intact.messages.size() << ", in that chunk "
        << intact.by_block.at(chunk).size() << "\n"
        << Listed(damaged.warnings);
    EXPECT_FALSE(damaged.truncated) << what;
    ASSERT_FALSE(damaged.warnings.empty()) << what;
    EXPECT_NE(damaged.warnings[0].find("skipped"), std::string::npos) << damaged.warnings[0];
    EXPECT_NE(damaged.warnings[0].find(std::to_string(chunk)), std::string::npos)
        << damaged.warnings[0];
  }
}

TEST(BagDamageTest, Ros1DamagedChunkCostsOnlyItsOwnMessages) {
  ExpectOnlyTheChunkLost(
      "teddy_realsense_lz4.bag", 2,
      {{"the header length's top bit flipped",
        [](std::vector<char>* bag, std::uint64_t chunk) { (*bag)[chunk + 3] ^= '\x80'; }},
       {"the header zeroed",
        [](std::vector<char>* bag, std::uint64_t chunk) {
          std::fill_n(bag->begin() + static_cast<std::ptrdiff_t>(chunk), 40, '\0');
        }},
       {"the data length made longer",
        [](std::vector<char>* bag, std::uint64_t chunk) {
          (*bag)[Ros1DataStart(*bag, chunk) - 2] ^= '\x01';  // + 64 KiB
        }},
       {"one bit of its lz4 data flipped", [](std::vector<char>* bag, std::uint64_t chunk) {
          (*bag)[Ros1DataStart(*bag, chunk) + 5000] ^= '\x04';
        }}});
}

// The first chunk holds the connection records of the topics it first carries: with it lost,
// their later messages are still read, the connections coming from the bag's index section.
TEST(BagDamageTest, Ros1TopicsOfALostFirstChunkComeFromTheIndex) {
  ExpectOnlyTheChunkLost(
      "teddy_realsense_lz4.bag", 0,
      {{"the first chunk's header zeroed", [](std::vector<char>* bag, std::uint64_t chunk) {
          std::fill_n(bag->begin() + static_cast<std::ptrdiff_t>(chunk), 40, '\0');
        }}});
}

TEST(BagDamageTest, McapDamagedChunkCostsOnlyItsOwnMessages) {
  ExpectOnlyTheChunkLost(
      "teddy_realsense.mcap", 2,
      {{"the record's op and length zeroed",
        [](std::vector<char>* bag, std::uint64_t chunk) {
          std::fill_n(bag->begin() + static_cast<std::ptrdiff_t>(chunk), 9, '\0');
        }},
       {"the length's top byte set",
        [](std::vector<char>* bag, std::uint64_t chunk) { (*bag)[chunk + 8] = '\x7f'; }},
       {"one bit of its zstd data flipped",
        [](std::vector<char>* bag, std::uint64_t chunk) { (*bag)[chunk + 9 + 2000] ^= '\x04'; }}});
}

// The first chunk holds the schema and channel records: with it lost, the channels come from the
// summary section.
TEST(BagDamageTest, McapChannelsOfALostFirstChunkComeFromTheSummary) {
  ExpectOnlyTheChunkLost(
      "teddy_realsense.mcap", 0,
      {{"the first chunk's op and length zeroed", [](std::vector<char>* bag, std::uint64_t chunk) {
          std::fill_n(bag->begin() + static_cast<std::ptrdiff_t>(chunk), 9, '\0');
        }}});
}

// A bag cut short still ends in "truncated", after every whole chunk before the cut.
TEST(BagDamageTest, ACutShortBagIsStillTruncatedNotResynchronised) {
  const std::optional<std::string> source = testing::SharedBag("teddy_realsense.mcap");
  if (!source) GTEST_SKIP() << "bags/teddy_realsense.mcap not in ../shared/data";
  const Contents intact = Read(*source);
  const std::vector<std::uint64_t> chunks = Chunks(intact);
  std::vector<char> bytes = Bytes(*source);
  const std::uint64_t cut = chunks[chunks.size() / 2] + 100;
  bytes.resize(cut);
  testing::TempDir dir;
  const Contents damaged = Read(Write(dir, "cut.mcap", bytes));
  EXPECT_TRUE(damaged.truncated);
  size_t before = 0;
  for (const auto& [block, messages] : intact.by_block)
    before += block < cut - 100 ? messages.size() : 0;
  EXPECT_EQ(damaged.messages.size(), before);
}

// Through the sequence: one damaged chunk in the middle of the 30-frame ROS 1 bag loses at most
// the frames whose colour or depth it held, and the sequence's warnings say what was skipped.
TEST(BagDamageTest, ADamagedChunkCostsAtMostTwoFrames) {
  const std::optional<std::string> source = testing::SharedBag("teddy_realsense_lz4.bag");
  if (!source) GTEST_SKIP() << "bags/teddy_realsense_lz4.bag not in ../shared/data";
  const Contents intact = Read(*source);
  const std::vector<std::uint64_t> chunks = Chunks(intact);
  testing::TempDir dir;
  const size_t all = Sequence::OpenBag(*source, {}, {}).frames().size();
  for (size_t k = 1; k + 1 < chunks.size(); k += 3) {
    std::vector<char> bytes = Bytes(*source);
    bytes[chunks[k] + 3] ^= '\x80';
    const Sequence damaged = Sequence::OpenBag(Write(dir, "damaged.bag", bytes), {}, {});
    EXPECT_GE(damaged.frames().size() + 2, all) << "chunk " << k << " of " << chunks.size();
    ASSERT_FALSE(damaged.warnings().empty());
    EXPECT_NE(damaged.warnings()[0].find("skipped"), std::string::npos);
  }
}

}  // namespace
}  // namespace stillmap
