// The blocks a bag reader decompressed last, most recent first: a colour/depth pair often spans
// two chunks, and frames are read in time order, so a few suffice.
#pragma once

#include <algorithm>
#include <cstdint>
#include <vector>

namespace stillmap {

class ChunkCache {
 public:
  // The block at `block`, from the cache or from load(block, &data) (which throws on failure).
  template <typename Load>
  const std::vector<std::uint8_t>& Get(std::uint64_t block, Load&& load) {
    for (size_t i = 0; i < entries_.size(); ++i) {
      if (entries_[i].block != block) continue;
      std::rotate(entries_.begin(), entries_.begin() + static_cast<std::ptrdiff_t>(i),
                  entries_.begin() + static_cast<std::ptrdiff_t>(i) + 1);
      return entries_.front().data;
    }
    Entry loaded{block, {}};
    load(block, &loaded.data);
    if (entries_.size() == kEntries) entries_.pop_back();
    entries_.insert(entries_.begin(), std::move(loaded));
    return entries_.front().data;
  }

 private:
  static constexpr size_t kEntries = 4;
  struct Entry {
    std::uint64_t block = 0;
    std::vector<std::uint8_t> data;
  };
  std::vector<Entry> entries_;
};

}  // namespace stillmap
