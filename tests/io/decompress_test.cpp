// Bag block decompression: a hand-made LZ4 frame whose last match starts 9 bytes before its
// block's end (the end-of-block rule liblz4 enforces, `lz4 -d` refuses it, and @mcap/core's
// JavaScript lz4 breaks) decodes to the bytes it was made from; damaged frames are refused,
// never read past, and a frame's checksums are checked whichever decoder reads it.
#include "bag/decompress.h"

#include <gtest/gtest.h>
#include <lz4frame.h>
#include <xxhash.h>

#include <algorithm>
#include <string>
#include <vector>

namespace stillmap {
namespace {

// One 64 KiB block (the frame's largest, so liblz4 decodes it in place and checks its end):
// "abcdefgh" and a match repeating it to 65518 bytes, "ijklmnopq", a match of 4 at offset 8
// ("jklm") starting 9 bytes before the block's end, then the literals "XYZWV".
std::vector<std::uint8_t> FrameBreakingTheEndRule() {
  std::vector<std::uint8_t> block = {0x8F, 'a', 'b', 'c', 'd', 'e', 'f', 'g', 'h', 8, 0};
  for (size_t left = 65510 - 4 - 15;; left -= 255) {  // the match length's extra bytes
    block.push_back(static_cast<std::uint8_t>(std::min<size_t>(left, 255)));
    if (left < 255) break;
  }
  for (const char c : std::string("\x90ijklmnopq\x08\x00\x50XYZWV", 18)) {
    block.push_back(static_cast<std::uint8_t>(c));
  }
  // Magic, FLG (version 1, linked blocks), BD (64 KiB blocks), header checksum.
  std::vector<std::uint8_t> frame = {0x04, 0x22, 0x4D, 0x18, 0x40, 0x40, 0xC0};
  frame.push_back(static_cast<std::uint8_t>(block.size() & 0xFFU));
  frame.push_back(static_cast<std::uint8_t>(block.size() >> 8U));
  frame.insert(frame.end(), {0, 0});
  frame.insert(frame.end(), block.begin(), block.end());
  frame.insert(frame.end(), {0, 0, 0, 0});  // end mark
  return frame;
}

std::string Expected() {
  std::string text;
  while (text.size() < 65518) text += "abcdefgh";
  text.resize(65518);
  return text + "ijklmnopqjklmXYZWV";
}

TEST(DecompressTest, Lz4FrameBreakingTheEndOfBlockRuleStillDecodes) {
  const std::vector<std::uint8_t> frame = FrameBreakingTheEndRule();
  std::vector<std::uint8_t> out;
  std::string error;
  ASSERT_TRUE(DecompressBlock("lz4", frame.data(), frame.size(), 65536, &out, &error)) << error;
  EXPECT_EQ(std::string(out.begin(), out.end()), Expected());
}

TEST(DecompressTest, DamagedLz4FramesAreRefused) {
  const std::vector<std::uint8_t> good = FrameBreakingTheEndRule();
  std::vector<std::uint8_t> out;
  std::string error;
  EXPECT_FALSE(DecompressBlock("lz4", good.data(), good.size(), 65537, &out, &error));  // size
  std::vector<std::uint8_t> far = good;
  far[7 + 4 + 9] = 9;  // the first match reaches before the frame's first byte
  EXPECT_FALSE(DecompressBlock("lz4", far.data(), far.size(), 65536, &out, &error));
  for (size_t cut = 0; cut < good.size(); ++cut) {
    EXPECT_FALSE(DecompressBlock("lz4", good.data(), cut, 65536, &out, &error)) << cut;
  }
  std::vector<std::uint8_t> long_block = good;
  long_block[9] = 0xFF;  // a block longer than the frame
  EXPECT_FALSE(DecompressBlock("lz4", long_block.data(), long_block.size(), 65536, &out, &error));
}

// The same frame with a content checksum (FLG bit 2): the hand decoder, which reads it after
// liblz4 refused the end rule, checks the checksum as liblz4 would.
TEST(DecompressTest, Lz4ContentChecksumIsCheckedWhenLiblz4RefusedTheFrame) {
  std::vector<std::uint8_t> frame = FrameBreakingTheEndRule();
  frame[4] |= 0x04U;
  const std::string expected = Expected();
  const std::uint32_t checksum = XXH32(expected.data(), expected.size(), 0);
  for (int byte = 0; byte < 4; ++byte) {
    frame.push_back(static_cast<std::uint8_t>(checksum >> (8U * static_cast<unsigned>(byte))));
  }
  std::vector<std::uint8_t> out;
  std::string error;
  ASSERT_TRUE(DecompressBlock("lz4", frame.data(), frame.size(), 65536, &out, &error)) << error;
  EXPECT_EQ(std::string(out.begin(), out.end()), expected);
  std::vector<std::uint8_t> flipped = frame;
  flipped[7 + 4 + 1] ^= 0x01U;  // the literal 'a' becomes '`': decodes, the checksum differs
  EXPECT_FALSE(DecompressBlock("lz4", flipped.data(), flipped.size(), 65536, &out, &error));
  EXPECT_NE(error.find("checksum"), std::string::npos) << error;
}

// A frame written by liblz4 with block and content checksums (as roslz4 writes ROS 1 chunks):
// one bit flipped in a block's stored bytes is refused, never decoded in silence.
TEST(DecompressTest, Lz4FrameWithAFlippedBitIsRefusedByItsChecksum) {
  std::vector<std::uint8_t> input(200000);
  for (size_t i = 0; i < input.size(); ++i) input[i] = static_cast<std::uint8_t>((i * 7) % 251);
  LZ4F_preferences_t preferences{};
  preferences.frameInfo.contentChecksumFlag = LZ4F_contentChecksumEnabled;
  std::vector<std::uint8_t> frame(LZ4F_compressFrameBound(input.size(), &preferences));
  const size_t size =
      LZ4F_compressFrame(frame.data(), frame.size(), input.data(), input.size(), &preferences);
  ASSERT_FALSE(LZ4F_isError(size));
  frame.resize(size);
  std::vector<std::uint8_t> out;
  std::string error;
  ASSERT_TRUE(DecompressBlock("lz4", frame.data(), frame.size(), input.size(), &out, &error));
  EXPECT_EQ(out, input);
  for (const size_t at : {size_t{20}, size / 2, size - 12}) {
    std::vector<std::uint8_t> flipped = frame;
    flipped[at] ^= 0x10U;
    EXPECT_FALSE(DecompressBlock("lz4", flipped.data(), flipped.size(), input.size(), &out, &error))
        << "bit flipped at byte " << at;
  }
}

}  // namespace
}  // namespace stillmap
