// An image topic judged by its messages: the messages of the encoding (or format) and size most
// of them have are kept; those without an image, of another kind, with a negative header stamp,
// stamped back in time (a clock reset) or repeating an earlier stamp are left out and counted.
#pragma once

#include <string>
#include <vector>

#include "bag/bag_streams.h"

namespace stillmap {

// What one image message is: "ENCODING WIDTHxHEIGHT" for a raw image, the format for a
// compressed one; empty when it holds no image or no readable header (*stamp is then left
// alone).
std::string ImageKey(const BagStream& stream, const BagMessage& message,
                     BagSerialization serialization, double* stamp);

// The messages of one image topic as the scan found them, in bag order, before it is judged.
struct ImageMessages {
  static constexpr size_t kNoImage = static_cast<size_t>(-1);
  std::vector<std::string> keys;  // distinct keys, in the order first met
  std::vector<size_t> key_of;     // per message: index into keys, or kNoImage
  std::vector<double> stamps;     // header stamps [s]
  std::vector<BagPosition> positions;

  void Add(const std::string& key, double stamp, const BagPosition& position);
};

// A header stamp this far before one already kept is a clock that went back [s]; less is
// messages recorded a little out of order, which pairing by stamp puts right.
constexpr double kClockJumpBack = 1.0;

// Fills the stream's kept messages (stamps, positions, count, detail, size) and appends one
// warning per reason messages were left out.
void JudgeImages(const ImageMessages& messages, const std::string& path, BagStream* stream,
                 std::vector<std::string>* warnings);

}  // namespace stillmap
