#include "stillmap/io/spill_file.h"

#include <fcntl.h>
#include <fmt/format.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <stdexcept>

namespace stillmap {
namespace {

// TMPDIR as the user set it (an error names it when it will not do), else /tmp.
std::string TemporaryFolder() {
  const char* folder = std::getenv("TMPDIR");
  return folder != nullptr && *folder != '\0' ? std::string(folder) : std::string("/tmp");
}

}  // namespace

SpillFile::SpillFile(std::string what) : what_(std::move(what)) {}

SpillFile::~SpillFile() {
  if (fd_ >= 0) ::close(fd_);
}

void SpillFile::Open() {
  folder_ = TemporaryFolder();
  fd_ = ::open(folder_.c_str(), O_TMPFILE | O_RDWR | O_CLOEXEC, 0600);
  if (fd_ < 0) {  // a file system without unnamed files: make one and take its name away
    std::string name = folder_ + "/stillmap-spill-XXXXXX";
    fd_ = ::mkstemp(name.data());
    if (fd_ >= 0) ::unlink(name.c_str());
  }
  if (fd_ < 0) {
    throw std::runtime_error(fmt::format(
        "cannot make a temporary file in {} for {} ({}); set TMPDIR to a writable folder", folder_,
        what_, std::strerror(errno)));
  }
}

SpillFile::Block SpillFile::Append(const std::vector<unsigned char>& bytes) {
  const std::lock_guard<std::mutex> lock(mutex_);
  if (fd_ < 0) Open();
  const Block block{end_, bytes.size()};
  size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t wrote = ::pwrite(fd_, bytes.data() + done, bytes.size() - done,
                                   static_cast<off_t>(block.offset + done));
    if (wrote < 0 && errno == EINTR) continue;
    if (wrote <= 0) {
      throw std::runtime_error(fmt::format(
          "cannot write {} to a temporary file in {} after {} MiB ({}); free space there or set "
          "TMPDIR to a folder with room",
          what_, folder_, end_ >> 20, std::strerror(wrote < 0 ? errno : ENOSPC)));
    }
    done += static_cast<size_t>(wrote);
  }
  end_ += bytes.size();
  return block;
}

std::vector<unsigned char> SpillFile::Read(const Block& block) const {
  std::vector<unsigned char> bytes(block.size);
  int fd = -1;
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    if (block.offset + block.size > end_) {
      throw std::runtime_error(fmt::format("{}: a block beyond the temporary file's end", what_));
    }
    fd = fd_;
  }
  size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t got = ::pread(fd, bytes.data() + done, bytes.size() - done,
                                static_cast<off_t>(block.offset + done));
    if (got < 0 && errno == EINTR) continue;
    if (got <= 0) {
      throw std::runtime_error(fmt::format("cannot read {} back from a temporary file in {} ({})",
                                           what_, folder_,
                                           got < 0 ? std::strerror(errno) : "it ended early"));
    }
    done += static_cast<size_t>(got);
  }
  return bytes;
}

std::uint64_t SpillFile::size() const {
  const std::lock_guard<std::mutex> lock(mutex_);
  return end_;
}

}  // namespace stillmap
