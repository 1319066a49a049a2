// Byte blocks parked in an unlinked temporary file and read back on request: what a build keeps
// for later but does not need in memory (the fused keyframes' compact copies), so that its
// memory grows with the map, not with the recording's length. The file lives in TMPDIR (else
// /tmp), has no name and goes with the process, however it ends.
#pragma once

#include <cstdint>
#include <mutex>
#include <string>
#include <vector>

namespace stillmap {

class SpillFile {
 public:
  struct Block {
    std::uint64_t offset = 0;
    std::uint64_t size = 0;
  };

  // `what` names the contents in errors ("the keyframe copies"). The file is made at the first
  // Append.
  explicit SpillFile(std::string what);
  ~SpillFile();
  SpillFile(const SpillFile&) = delete;
  SpillFile& operator=(const SpillFile&) = delete;

  // Writes `bytes` at the file's end. Throws std::runtime_error naming the folder (and TMPDIR)
  // when the file cannot be made or written (a full disk). Safe to call from several threads.
  Block Append(const std::vector<unsigned char>& bytes);
  // Reads a block written before. Throws std::runtime_error when it cannot.
  std::vector<unsigned char> Read(const Block& block) const;
  // Bytes written so far.
  std::uint64_t size() const;

 private:
  void Open();  // under mutex_

  std::string what_;
  std::string folder_;
  mutable std::mutex mutex_;
  int fd_ = -1;
  std::uint64_t end_ = 0;
};

}  // namespace stillmap
