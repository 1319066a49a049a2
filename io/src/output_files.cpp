#include "stillmap/io/output_files.h"

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <system_error>

#include "stillmap/io/error.h"

namespace stillmap {

namespace fs = std::filesystem;

std::string TemporaryPathFor(const std::string& path) {
  const fs::path p(path);
  return (p.parent_path() / ("." + p.filename().string() + ".tmp")).string();
}

void CommitTemporary(const std::string& temporary, const std::string& final_path) {
  std::error_code error;
  fs::rename(temporary, final_path, error);
  if (error) {
    throw std::runtime_error("could not rename " + temporary + " to " + final_path + ": " +
                             error.message());
  }
}

void PrepareOutputFolder(const std::string& dir) {
  std::error_code error;
  fs::create_directories(dir, error);
  if (error || !fs::is_directory(dir)) {
    throw InputError(dir + ": cannot create the output folder (" +
                     (error ? error.message() : std::string("a file has that name")) +
                     "); choose another -o");
  }
  const std::string probe = (fs::path(dir) / ".stillmap_write_probe.tmp").string();
  {
    std::ofstream out(probe);
    if (!out || !(out << "probe") || !out.flush()) {
      throw InputError(dir + ": the output folder is not writable; choose another -o");
    }
  }
  std::remove(probe.c_str());
}

OutputSet::OutputSet(std::string dir) : dir_(std::move(dir)) {}

OutputSet::~OutputSet() {
  if (committed_) return;
  for (const std::string& name : names_) std::remove(TemporaryPathFor(FinalPath(name)).c_str());
}

std::string OutputSet::TemporaryPath(const std::string& name) {
  names_.push_back(name);
  return TemporaryPathFor(FinalPath(name));
}

std::string OutputSet::FinalPath(const std::string& name) const {
  return (fs::path(dir_) / name).string();
}

void OutputSet::Commit() {
  for (const std::string& name : names_) {
    CommitTemporary(TemporaryPathFor(FinalPath(name)), FinalPath(name));
  }
  committed_ = true;
}

}  // namespace stillmap
