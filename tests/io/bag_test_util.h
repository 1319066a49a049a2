// What the bag reader tests share: the sequence's lists by stamp, a whole scan kept, and a CDR
// writer for messages made in a test.
#pragma once

#include <cstdio>
#include <fstream>
#include <map>
#include <string>
#include <vector>

#include "stillmap/io/bag_reader.h"

namespace stillmap {

// rgb.txt's or depth.txt's lines: stamp -> file, as written.
inline std::map<std::string, std::string> ListOf(const std::string& sequence,
                                                 const std::string& list) {
  std::map<std::string, std::string> files;
  std::ifstream in(sequence + "/" + list);
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    const size_t space = line.find(' ');
    files[line.substr(0, space)] = line.substr(space + 1);
  }
  return files;
}

inline std::string Stamp(double t) {
  char text[32];
  std::snprintf(text, sizeof(text), "%.6f", t);
  return text;
}

struct Scanned {
  std::map<std::string, std::vector<BagMessage>> by_topic;  // data pointers not kept
  std::map<std::string, std::vector<std::vector<std::uint8_t>>> data;
};

inline Scanned ScanAll(BagReader& bag) {
  Scanned scanned;
  bag.Scan([&](const BagMessage& message) {
    const std::string& topic = bag.topics().at(message.topic).name;
    scanned.by_topic[topic].push_back(message);
    scanned.data[topic].emplace_back(message.data, message.data + message.size);
  });
  return scanned;
}

// A little-endian CDR writer: each primitive aligned to its size from after the 4-byte header.
class Cdr {
 public:
  Cdr() : bytes_{0x00, 0x01, 0x00, 0x00} {}
  void U8(std::uint8_t value) { Put(&value, 1); }
  void U32(std::uint32_t value) { Put(&value, 4); }
  void F64(double value) { Put(&value, 8); }
  void String(const std::string& text) {
    U32(static_cast<std::uint32_t>(text.size() + 1));
    bytes_.insert(bytes_.end(), text.begin(), text.end());
    bytes_.push_back(0);
  }
  const std::vector<std::uint8_t>& bytes() const { return bytes_; }

 private:
  void Put(const void* value, size_t size) {
    while ((bytes_.size() - 4) % size != 0) bytes_.push_back(0);
    const auto* p = static_cast<const std::uint8_t*>(value);
    bytes_.insert(bytes_.end(), p, p + size);
  }
  std::vector<std::uint8_t> bytes_;
};

}  // namespace stillmap
