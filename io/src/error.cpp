#include "stillmap/io/error.h"

namespace stillmap {

std::string WhereInFile(const std::string& path, int line) {
  if (line <= 0) return path;
  return path + ":" + std::to_string(line);
}

std::string Quoted(const std::string& text, size_t max_chars) {
  static const char kHex[] = "0123456789abcdef";
  std::string quoted;
  for (size_t i = 0; i < text.size(); ++i) {
    if (quoted.size() >= max_chars) return quoted + "...";
    const auto byte = static_cast<unsigned char>(text[i]);
    if (byte >= 0x20 && byte < 0x7f) {
      quoted += static_cast<char>(byte);
    } else {
      quoted += std::string("\\x") + kHex[byte >> 4] + kHex[byte & 0xf];
    }
  }
  return quoted;
}

}  // namespace stillmap
