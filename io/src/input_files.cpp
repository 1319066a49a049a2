#include "stillmap/io/input_files.h"

#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <system_error>

#include "stillmap/io/error.h"

namespace stillmap {

namespace fs = std::filesystem;

std::string StatProblem(const std::error_code& error) {
  if (!error) return "unknown file type";
  if (error.value() == ELOOP) return "a loop of symbolic links: the link leads back to itself";
  if (error.value() == EACCES) return "permission denied on a folder on its path";
  return error.message();
}

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
      throw InputError(path + ": cannot open the " + what + " (" + StatProblem(error) + ")");
    default:
      throw InputError(path + ": the " + what +
                       " is not a regular file (a FIFO, socket or device); give a file");
  }
  if (::access(path.c_str(), R_OK) != 0) {
    throw InputError(path + ": cannot read the " + what + " (" + std::strerror(errno) + ")");
  }
}

void CheckSequenceFolder(const std::string& path) {
  const std::string expected =
      " (expected a TUM-layout folder with rgb.txt and depth.txt, a ROS 1 .bag, an .mcap or .db3 "
      "file, or a ROS 2 bag folder)";
  std::error_code error;
  const fs::file_status status = fs::status(path, error);
  switch (status.type()) {
    case fs::file_type::directory:
      break;
    case fs::file_type::not_found:
      throw InputError(path + ": sequence folder not found" + expected);
    case fs::file_type::regular: {
      const std::uintmax_t size = fs::file_size(path, error);
      if (size == 0) {
        throw InputError(path + ": an empty file (0 bytes), not a recording" + expected);
      }
      throw InputError(path + ": a file of " + std::to_string(size) +
                       " bytes that is not a bag stillmap reads (it does not start as a ROS 1 "
                       "bag, an MCAP or a SQLite file does; cut short or another format?)" +
                       expected);
    }
    case fs::file_type::none:
    case fs::file_type::unknown:
      throw InputError(path + ": cannot open the sequence (" + StatProblem(error) + ")");
    default:
      throw InputError(path + ": a FIFO, socket or device, not a sequence" + expected);
  }
  if (fs::is_empty(path, error) && !error) throw InputError(path + ": an empty folder" + expected);
  if (!PathExists((fs::path(path) / "rgb.txt").string())) {
    throw InputError(path + ": no rgb.txt in the folder, and no bag files" + expected);
  }
}

bool PathExists(const std::string& path) {
  std::error_code error;
  return fs::exists(fs::symlink_status(path, error));
}

}  // namespace stillmap
