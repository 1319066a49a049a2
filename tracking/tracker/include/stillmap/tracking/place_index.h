// Place recognition without a trained vocabulary: an index over the keyframes' ORB descriptors,
// built while the sequence runs, that answers "which keyframes saw this view?" with keyframes
// ranked by votes. Candidates are only candidates: the tracker verifies each geometrically.
//
// Locality-sensitive hashing by bit sampling (Gionis, Indyk and Motwani; the scheme of FLANN's
// LshIndex): each of `tables` hash tables keys a descriptor by `key_bits` of its 256 bits, so
// descriptors within a small Hamming distance share a bucket in at least one table with high
// probability. Written here rather than taken from FLANN (a design-card package): FLANN 1.9's
// LshTable draws its bit masks from std::random_device, so two runs would index differently and a
// build would not repeat (issue 33); here the masks come from a generator with the seed given
// (the tracker gives a fixed one).
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <opencv2/core.hpp>
#include <vector>

#include "stillmap/io/mapped_pages.h"

namespace stillmap {

struct PlaceIndexOptions {
  static constexpr int kMaxKeyBits = 20;  // a table's keys then take 4 MiB
  int tables = 8;                         // hash tables
  int key_bits = 16;      // bits of a descriptor that make a key (each table holds 4 bytes a key)
  int max_distance = 50;  // a query descriptor votes for keyframes holding one this close
                          // (Hamming, of 256 bits; ORB-SLAM2's TH_LOW)

  // Throws InputError naming the key (tracking.place_*) of the first impossible value.
  void Validate() const;

  template <typename Self, typename Visitor>
  static void VisitFields(Self& self, Visitor& visit) {
    visit("tables", self.tables, "hash tables of the place index (bit-sampling LSH)");
    visit("key_bits", self.key_bits, "descriptor bits per hash key of the place index");
    visit("max_distance", self.max_distance,
          "a descriptor votes for keyframes holding one within this Hamming distance (of 256)");
  }
};

struct PlaceCandidate {
  int keyframe_id = 0;
  int votes = 0;  // query descriptors with a close descriptor in the keyframe
};

class PlaceIndex {
 public:
  PlaceIndex(const PlaceIndexOptions& options, std::uint64_t seed);

  // Indexes a keyframe's descriptors (CV_8U rows of 32 bytes); a keyframe id is added once.
  void Add(int keyframe_id, const cv::Mat& descriptors);
  // Forgets a keyframe (its entries are skipped, and dropped at the next compaction).
  void Remove(int keyframe_id);

  // The keyframes with votes from `descriptors`, most votes first (ties: lower id first), at
  // most `max_candidates`; keyframes for which `skip` returns true are left out.
  template <typename Skip>
  std::vector<PlaceCandidate> Query(const cv::Mat& descriptors, size_t max_candidates,
                                    Skip&& skip) const {
    std::vector<PlaceCandidate> out;
    for (const auto& [id, votes] : Votes(descriptors)) {
      if (!skip(id)) out.push_back({id, votes});
    }
    return Ranked(std::move(out), max_candidates);
  }

  size_t keyframes() const { return keyframe_count_; }
  size_t entries() const { return descriptors_.size() - removed_entries_; }  // live ones
  size_t MemoryBytes() const;

 private:
  using Bits = std::array<std::uint64_t, 4>;
  std::uint32_t Key(const Bits& bits, size_t table) const;
  // Votes per keyframe id (std::map: the order does not depend on addresses).
  std::map<int, int> Votes(const cv::Mat& descriptors) const;
  static std::vector<PlaceCandidate> Ranked(std::vector<PlaceCandidate> candidates, size_t count);
  void Compact();
  // Files descriptor `index` under its key in every table.
  void AddToTables(std::uint32_t index);

  // The index lies in pages of its own (mapped_pages.h), the tables' buckets too, rather than in a
  // small list per key: those many small blocks stayed in the heap once the index was freed,
  // pinned by the build's other small blocks (docs/figures.md, issue 47). A bucket is a chain of
  // chunks, newest first.
  struct Chunk {
    static constexpr std::uint32_t kItems = 14;  // a chunk fills a 64-byte cache line
    std::uint32_t items[kItems];                 // descriptor numbers
    std::uint32_t count;
    std::uint32_t older;  // the bucket's chunk before this one + 1, 0 = none
  };
  struct Table {
    std::vector<std::uint32_t> newest;  // per key: the bucket's newest chunk + 1, 0 = empty
    PagedArray<Chunk, 10> chunks;       // 64 KiB pages
  };
  // Calls visit(descriptor number) for each descriptor in the bucket of `key` in `table`.
  template <typename Visit>
  static void ForEachInBucket(const Table& table, std::uint32_t key, Visit&& visit) {
    for (std::uint32_t c = table.newest[key]; c != 0; c = table.chunks[c - 1].older) {
      const Chunk& chunk = table.chunks[c - 1];
      for (std::uint32_t i = 0; i < chunk.count; ++i) visit(chunk.items[i]);
    }
  }

  PlaceIndexOptions options_;
  std::vector<std::vector<int>> key_bit_positions_;  // per table
  std::vector<Table> tables_;
  using DescriptorPages = PagedArray<Bits, 11>;  // 64 KiB pages
  using OwnerPages = PagedArray<int, 14>;
  DescriptorPages descriptors_;
  OwnerPages owner_;  // keyframe id per descriptor, -1 once removed
  // A keyframe's descriptors: contiguous in descriptors_ (Add appends them, Compact keeps the
  // order), so that removing one touches its own entries only.
  struct Entries {
    std::uint32_t first = 0, count = 0;
    bool live = true;  // still indexed
  };
  std::map<int, Entries> indexed_;  // by keyframe id
  size_t keyframe_count_ = 0;
  size_t removed_entries_ = 0;
};

}  // namespace stillmap
