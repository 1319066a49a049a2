#include "stillmap/io/error.h"

#include <cerrno>
#include <cstring>

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

std::string WriteFailure(const std::string& path, const std::string& what) {
  const int error = errno;
  std::string reason;
  switch (error) {
    case ENOSPC:
      reason = "the disk is full (no space left on the device); free space or write elsewhere";
      break;
    case EDQUOT:
      reason = "the disk quota is used up; free space or write elsewhere";
      break;
    case EROFS:
      reason = "the file system is read-only; write elsewhere";
      break;
    case EACCES:
    case EPERM:
      reason = "permission denied; write to a folder you may write to";
      break;
    case EFBIG:
      reason = "the file is larger than the file system or the process's limit allows";
      break;
    case EIO:
      reason = "an input/output error (a failing disk, or a drive removed?)";
      break;
    default:
      reason = error != 0 ? std::strerror(error) : "the write failed";
  }
  return path + ": could not write " + what + ": " + reason;
}

}  // namespace stillmap
