#include "stillmap/io/error.h"

namespace stillmap {

std::string WhereInFile(const std::string& path, int line) {
  if (line <= 0) return path;
  return path + ":" + std::to_string(line);
}

}  // namespace stillmap
