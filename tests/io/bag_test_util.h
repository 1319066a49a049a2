// What the bag reader tests share: the sequence's lists by stamp, and a whole scan kept.
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

}  // namespace stillmap
