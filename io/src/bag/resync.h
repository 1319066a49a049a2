// Finding where a bag can be read on after damage, shared by the ROS 1 and MCAP readers: the next
// record the bag's own index (or summary) lists that still looks whole bounds the search, and the
// bytes up to it are searched too, in windows, in case the index misses a record.
#pragma once

#include <algorithm>
#include <cstdint>
#include <fstream>
#include <string>
#include <vector>

namespace stillmap {

// The first of `listed` (sorted offsets) after `from` for which `whole(offset)` holds; `none`
// when there is none.
template <typename Whole>
std::uint64_t NextListed(const std::vector<std::uint64_t>& listed, std::uint64_t from,
                         std::uint64_t none, Whole whole) {
  for (auto it = std::upper_bound(listed.begin(), listed.end(), from); it != listed.end(); ++it) {
    if (whole(*it)) return *it;
  }
  return none;
}

// The first offset in (from, limit) at which `starts(bytes, available, offset)` holds, reading
// the file in 1 MiB windows that overlap by `lookahead` bytes (what `starts` needs to see past the
// offset); `limit` when there is none.
template <typename Starts>
std::uint64_t ScanForward(std::ifstream& file, std::uint64_t file_size, std::uint64_t from,
                          std::uint64_t limit, size_t lookahead, Starts starts) {
  constexpr std::uint64_t kWindow = 1U << 20U;
  std::vector<std::uint8_t> window;
  for (std::uint64_t start = from + 1; start < limit && start < file_size; start += kWindow) {
    window.resize(
        static_cast<size_t>(std::min<std::uint64_t>(kWindow + lookahead, file_size - start)));
    file.clear();
    file.seekg(static_cast<std::streamoff>(start));
    file.read(reinterpret_cast<char*>(window.data()), static_cast<std::streamsize>(window.size()));
    if (!file) break;
    for (size_t i = 0; i < window.size() && i < kWindow && start + i < limit; ++i) {
      if (starts(window.data() + i, window.size() - i, start + i)) return start + i;
    }
  }
  return limit;
}

// The warnings of a re-synchronisation: bytes `from` to `to` skipped (with what was wrong, when
// known); a chunk at `offset` that did not load, read on from `next` (nothing more when `next`
// reaches the file's end).
inline std::string SkippedBytes(std::uint64_t from, std::uint64_t to, const std::string& damage) {
  return "bytes " + std::to_string(from) + " to " + std::to_string(to) + " (" +
         std::to_string(to - from) + " bytes) are damaged" +
         (damage.empty() ? std::string() : " (" + damage + ")") +
         " and skipped; the bag is read on from byte " + std::to_string(to);
}

inline std::string SkippedChunk(std::uint64_t offset, const std::string& error, std::uint64_t next,
                                std::uint64_t file_size) {
  return "the chunk at byte " + std::to_string(offset) + " is skipped (" + error + "); " +
         (next < file_size ? "the bag is read on from byte " + std::to_string(next)
                           : std::string("nothing after it could be read"));
}

}  // namespace stillmap
