#include "bag/rvl.h"

#include "bag/bytes.h"

namespace stillmap {
namespace {

// RVL's variable-length integers: 3-bit groups, low first, each in a nibble whose high bit says
// that another follows; nibbles fill 32-bit little-endian words from their high end.
class Nibbles {
 public:
  Nibbles(const std::uint8_t* data, size_t size) : data_(data), words_(size / 4) {}
  bool Next(std::uint32_t* value) {
    *value = 0;
    for (unsigned shift = 0; shift < 32; shift += 3) {
      if (left_ == 0) {
        if (word_index_ == words_) return false;
        word_ = Le32(data_ + 4 * word_index_++);
        left_ = 8;
      }
      const std::uint32_t nibble = word_ >> 28U;
      word_ <<= 4U;
      --left_;
      *value |= (nibble & 0x7U) << shift;
      if ((nibble & 0x8U) == 0) return true;
    }
    return false;  // more groups than a 32-bit value holds
  }

 private:
  const std::uint8_t* data_;
  size_t words_, word_index_ = 0;
  std::uint32_t word_ = 0;
  int left_ = 0;
};

}  // namespace

bool DecodeRvl(const std::uint8_t* data, size_t size, std::uint16_t* out, size_t pixels) {
  Nibbles nibbles(data, size);
  size_t at = 0;
  std::uint16_t previous = 0;
  while (at < pixels) {
    std::uint32_t zeros = 0, values = 0;
    if (!nibbles.Next(&zeros) || zeros > pixels - at) return false;
    for (const size_t end = at + zeros; at < end; ++at) out[at] = 0;
    if (!nibbles.Next(&values) || values > pixels - at) return false;
    for (const size_t end = at + values; at < end; ++at) {
      std::uint32_t zigzag = 0;
      if (!nibbles.Next(&zigzag)) return false;
      const auto delta = static_cast<std::int32_t>((zigzag >> 1U) ^ (0U - (zigzag & 1U)));
      previous = static_cast<std::uint16_t>(previous + delta);
      out[at] = previous;
    }
  }
  return true;
}

}  // namespace stillmap
