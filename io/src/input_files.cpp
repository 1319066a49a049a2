#include "stillmap/io/input_files.h"

#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <system_error>

#include "stillmap/io/error.h"

namespace stillmap {

namespace fs = std::filesystem;

void CheckInputFile(const std::string& path, const std::string& what) {
  std::error_code error;
  const fs::file_status status = fs::status(path, error);
  switch (status.type()) {
    case fs::file_type::regular:
      break;
    case fs::file_type::not_found:
      throw InputError(path + ": cannot open the " + what + ": no such file");
    case fs::file_type::directory:
      throw InputError(path + ": the " + what + " is a folder, not a file");
    case fs::file_type::none:  // stat failed for another reason (a symbolic link loop, ...)
    case fs::file_type::unknown:
      throw InputError(path + ": cannot open the " + what + " (" +
                       (error ? error.message() : std::string("unknown file type")) + ")");
    default:
      throw InputError(path + ": the " + what +
                       " is not a regular file (a FIFO, socket or device); give a file");
  }
  if (::access(path.c_str(), R_OK) != 0) {
    throw InputError(path + ": cannot read the " + what + " (" + std::strerror(errno) + ")");
  }
}

bool PathExists(const std::string& path) {
  std::error_code error;
  return fs::exists(fs::symlink_status(path, error));
}

}  // namespace stillmap
