#include "stillmap/io/bag_reader.h"

#include <cstdio>
#include <cstring>
#include <fstream>

#include "stillmap/io/error.h"

namespace stillmap {

std::uint64_t BagReader::CheckMagic(const char* magic, size_t magic_size,
                                    const std::string& what) const {
  std::ifstream file(path_, std::ios::binary | std::ios::ate);
  if (!file) throw InputError(path_ + ": cannot open the bag");
  const auto size = static_cast<std::uint64_t>(file.tellg());
  std::vector<char> start(magic_size, '\0');
  file.seekg(0);
  file.read(start.data(), static_cast<std::streamsize>(magic_size));
  if (!file || std::memcmp(start.data(), magic, magic_size) != 0) {
    throw InputError(path_ + ": not " + what);
  }
  return size;
}

void BagReader::WarnTruncated(std::uint64_t offset, std::uint64_t file_size, double last_time,
                              const std::string& damage) {
  char seconds[32];
  std::snprintf(seconds, sizeof(seconds), "%.3f", last_time);
  truncated_ = true;
  warnings_.push_back(path_ + ": truncated at byte " + std::to_string(offset) + " of " +
                      std::to_string(file_size) + (damage.empty() ? "" : " (" + damage + ")") +
                      ": the recording ends at t = " + seconds + " s; what comes before is read");
}

}  // namespace stillmap
