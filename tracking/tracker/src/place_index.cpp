#include "stillmap/tracking/place_index.h"

#include <fmt/format.h>

#include <algorithm>
#include <cstring>
#include <numeric>
#include <random>

#include "hamming.h"
#include "stillmap/io/error.h"
#include "stillmap/io/option_names.h"

namespace stillmap {

void PlaceIndexOptions::Validate() const {
  if (tables < 1 || tables > 64)
    throw InputError(fmt::format("{} must be 1..64", OptionKey(*this, tables)));
  if (key_bits < 4 || key_bits > 32)
    throw InputError(fmt::format("{} must be 4..32", OptionKey(*this, key_bits)));
  if (max_distance < 0 || max_distance > 256) {
    throw InputError(fmt::format("{} must be 0..256", OptionKey(*this, max_distance)));
  }
}

PlaceIndex::PlaceIndex(const PlaceIndexOptions& options, std::uint64_t seed)
    : options_(options), buckets_(static_cast<size_t>(options.tables)) {
  options_.Validate();
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
  for (size_t t = 0; t < buckets_.size(); ++t) {
    const auto [bucket, added] = buckets_[t].try_emplace(Key(descriptors_[index], t));
    if (added) table_bytes_ += sizeof(std::uint32_t) + sizeof(std::vector<std::uint32_t>);
    const size_t capacity = bucket->second.capacity();
    bucket->second.push_back(index);
    table_bytes_ += (bucket->second.capacity() - capacity) * sizeof(std::uint32_t);
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
  std::vector<Bits> descriptors;
  std::vector<int> owner;
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
  descriptors_.swap(descriptors);
  owner_.swap(owner);
  removed_entries_ = 0;
  for (auto& table : buckets_) table.clear();
  table_bytes_ = 0;
  for (size_t i = 0; i < descriptors_.size(); ++i) AddToTables(static_cast<std::uint32_t>(i));
}

std::map<int, int> PlaceIndex::Votes(const cv::Mat& descriptors) const {
  std::map<int, int> votes;
  std::vector<std::pair<int, int>> hits;  // (keyframe id, distance) of one query descriptor
  for (int row = 0; row < descriptors.rows; ++row) {
    Bits query;
    std::memcpy(query.data(), descriptors.ptr<std::uint8_t>(row), sizeof(query));
    hits.clear();
    for (size_t t = 0; t < buckets_.size(); ++t) {
      const auto bucket = buckets_[t].find(Key(query, t));
      if (bucket == buckets_[t].end()) continue;
      for (const std::uint32_t index : bucket->second) {
        const int owner = owner_[index];
        if (owner < 0) continue;
        const Bits& d = descriptors_[index];
        const int distance = HammingDistance(query, d);
        if (distance <= options_.max_distance) hits.emplace_back(owner, distance);
      }
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
  return descriptors_.capacity() * sizeof(Bits) + owner_.capacity() * sizeof(int) + table_bytes_;
}

}  // namespace stillmap
