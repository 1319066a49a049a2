#include "stillmap/tracking/place_index.h"

#include <fmt/format.h>

#include <algorithm>
#include <cstring>
#include <numeric>
#include <random>
#include <utility>

#include "hamming.h"
#include "stillmap/io/error.h"
#include "stillmap/io/option_names.h"

namespace stillmap {

void PlaceIndexOptions::Validate() const {
  if (tables < 1 || tables > 64)
    throw InputError(fmt::format("{} must be 1..64", OptionKey(*this, tables)));
  if (key_bits < 4 || key_bits > kMaxKeyBits) {
    throw InputError(fmt::format("{} must be 4..{} (each table holds 4 bytes for each key)",
                                 OptionKey(*this, key_bits), kMaxKeyBits));
  }
  if (max_distance < 0 || max_distance > 256) {
    throw InputError(fmt::format("{} must be 0..256", OptionKey(*this, max_distance)));
  }
}

PlaceIndex::PlaceIndex(const PlaceIndexOptions& options, std::uint64_t seed) : options_(options) {
  options_.Validate();
  tables_.resize(static_cast<size_t>(options_.tables));
  for (Table& table : tables_) table.newest.assign(size_t{1} << options_.key_bits, 0);
  std::mt19937_64 generator(seed);
  std::vector<int> positions(256);
  for (int t = 0; t < options_.tables; ++t) {
    std::iota(positions.begin(), positions.end(), 0);
    // A Fisher-Yates shuffle written out: std::shuffle's use of the generator is not specified,
    // so the masks would differ between standard libraries.
    for (size_t i = positions.size() - 1; i > 0; --i) {
      std::swap(positions[i], positions[generator() % (i + 1)]);
    }
    key_bit_positions_.emplace_back(positions.begin(), positions.begin() + options_.key_bits);
  }
}

std::uint32_t PlaceIndex::Key(const Bits& bits, size_t table) const {
  std::uint32_t key = 0;
  for (const int position : key_bit_positions_[table]) {
    const auto p = static_cast<unsigned>(position);
    key = (key << 1U) | static_cast<std::uint32_t>((bits[p / 64U] >> (p % 64U)) & 1U);
  }
  return key;
}

void PlaceIndex::Add(int keyframe_id, const cv::Mat& descriptors) {
  if (indexed_.count(keyframe_id) > 0) return;
  Entries& entries = indexed_[keyframe_id];
  entries.first = static_cast<std::uint32_t>(descriptors_.size());
  entries.count = static_cast<std::uint32_t>(descriptors.rows);
  ++keyframe_count_;
  for (int row = 0; row < descriptors.rows; ++row) {
    Bits bits;
    std::memcpy(bits.data(), descriptors.ptr<std::uint8_t>(row), sizeof(bits));
    descriptors_.push_back(bits);
    owner_.push_back(keyframe_id);
    AddToTables(static_cast<std::uint32_t>(descriptors_.size() - 1));
  }
}

void PlaceIndex::AddToTables(std::uint32_t index) {
  for (size_t t = 0; t < tables_.size(); ++t) {
    Table& table = tables_[t];
    std::uint32_t& newest = table.newest[Key(descriptors_[index], t)];
    if (newest == 0 || table.chunks[newest - 1].count == Chunk::kItems) {
      Chunk chunk{};
      chunk.older = newest;
      table.chunks.push_back(chunk);
      newest = static_cast<std::uint32_t>(table.chunks.size());
    }
    Chunk& chunk = table.chunks[newest - 1];
    chunk.items[chunk.count++] = index;
  }
}

void PlaceIndex::Remove(int keyframe_id) {
  const auto it = indexed_.find(keyframe_id);
  if (it == indexed_.end() || !it->second.live) return;
  it->second.live = false;
  --keyframe_count_;
  for (std::uint32_t i = it->second.first; i < it->second.first + it->second.count; ++i) {
    owner_[i] = -1;
  }
  removed_entries_ += it->second.count;
  it->second.count = 0;
  if (removed_entries_ * 2 > owner_.size()) Compact();
}

void PlaceIndex::Compact() {
  DescriptorPages descriptors;
  OwnerPages owner;
  std::vector<std::uint32_t> moved_to(owner_.size(), 0);  // old index -> new index
  for (size_t i = 0; i < owner_.size(); ++i) {
    moved_to[i] = static_cast<std::uint32_t>(descriptors.size());
    if (owner_[i] < 0) continue;
    descriptors.push_back(descriptors_[i]);
    owner.push_back(owner_[i]);
  }
  for (auto& [id, entries] : indexed_) {
    if (entries.count > 0) entries.first = moved_to[entries.first];
  }
  descriptors_ = std::move(descriptors);
  owner_ = std::move(owner);
  removed_entries_ = 0;
  for (Table& table : tables_) {
    std::fill(table.newest.begin(), table.newest.end(), 0);
    table.chunks.clear();
  }
  for (size_t i = 0; i < descriptors_.size(); ++i) AddToTables(static_cast<std::uint32_t>(i));
}

std::map<int, int> PlaceIndex::Votes(const cv::Mat& descriptors) const {
  std::map<int, int> votes;
  std::vector<std::pair<int, int>> hits;  // (keyframe id, distance) of one query descriptor
  for (int row = 0; row < descriptors.rows; ++row) {
    Bits query;
    std::memcpy(query.data(), descriptors.ptr<std::uint8_t>(row), sizeof(query));
    hits.clear();
    for (size_t t = 0; t < tables_.size(); ++t) {
      ForEachInBucket(tables_[t], Key(query, t), [&](std::uint32_t index) {
        const int owner = owner_[index];
        if (owner < 0) return;
        const int distance = HammingDistance(query, descriptors_[index]);
        if (distance <= options_.max_distance) hits.emplace_back(owner, distance);
      });
    }
    std::sort(hits.begin(), hits.end());
    for (size_t i = 0; i < hits.size(); ++i) {
      if (i == 0 || hits[i].first != hits[i - 1].first) ++votes[hits[i].first];
    }
  }
  return votes;
}

std::vector<PlaceCandidate> PlaceIndex::Ranked(std::vector<PlaceCandidate> candidates,
                                               size_t count) {
  std::sort(candidates.begin(), candidates.end(),
            [](const PlaceCandidate& a, const PlaceCandidate& b) {
              return a.votes != b.votes ? a.votes > b.votes : a.keyframe_id < b.keyframe_id;
            });
  if (candidates.size() > count) candidates.resize(count);
  return candidates;
}

size_t PlaceIndex::MemoryBytes() const {
  size_t bytes = descriptors_.MemoryBytes() + owner_.MemoryBytes();
  for (const Table& table : tables_) {
    bytes += table.newest.capacity() * sizeof(std::uint32_t) + table.chunks.MemoryBytes();
  }
  return bytes;
}

}  // namespace stillmap
