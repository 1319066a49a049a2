#include "stillmap/io/output_files.h"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <system_error>

#include "stillmap/io/error.h"

namespace stillmap {

namespace fs = std::filesystem;

namespace {

constexpr char kLockName[] = ".stillmap.lock";
constexpr char kStagingName[] = ".stillmap-staging";
constexpr char kPreviousName[] = ".stillmap-previous";
constexpr char kAllMovedName[] = ".all-moved";  // in kPreviousName: the earlier set is all aside

std::string Bare(const std::string& name) {
  return !name.empty() && name.back() == '/' ? name.substr(0, name.size() - 1) : name;
}

bool Exists(const fs::path& path) {
  std::error_code error;
  return fs::exists(fs::symlink_status(path, error));
}

std::string ReadPid(const std::string& lock_path) {
  std::ifstream in(lock_path);
  std::string pid;
  in >> pid;
  return pid.empty() ? std::string() : " (process " + pid + ")";
}

}  // namespace

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

OutputSet::OutputSet(std::string dir, std::vector<std::string> owned_names)
    : dir_(std::move(dir)), owned_names_(std::move(owned_names)) {
  const fs::path folder(dir_);
  std::error_code error;
  const bool existed = fs::exists(folder, error);
  if (error) {
    throw InputError(dir_ + ": cannot use the output folder (" + error.message() +
                     "); choose another");
  }
  fs::create_directories(folder, error);
  if (error || !fs::is_directory(folder)) {
    throw InputError(dir_ + ": cannot create the output folder (" +
                     (error ? error.message() : std::string("a file has that name")) +
                     "); choose another");
  }
  created_dir_ = !existed;
  staging_ = (folder / kStagingName).string();
  try {
    const std::string lock_path = (folder / kLockName).string();
    lock_fd_ = ::open(lock_path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
    if (lock_fd_ < 0) {
      throw InputError(dir_ + ": the output folder is not writable (" + std::strerror(errno) +
                       "); choose another");
    }
    if (::flock(lock_fd_, LOCK_EX | LOCK_NB) != 0) {
      throw InputError(dir_ + ": another stillmap run is writing into this folder" +
                       ReadPid(lock_path) + "; wait for it to finish or choose another folder");
    }
    const std::string pid = std::to_string(::getpid()) + "\n";
    if (::ftruncate(lock_fd_, 0) != 0 ||
        ::write(lock_fd_, pid.data(), pid.size()) != static_cast<ssize_t>(pid.size())) {
      throw InputError(dir_ + ": the output folder is not writable; choose another");
    }
    Recover();
    for (const std::string& name : owned_names_) {
      const fs::path path = folder / Bare(name);
      if (!Exists(path)) continue;
      const bool folder_expected = name.back() == '/';
      if (fs::is_directory(fs::symlink_status(path)) != folder_expected) {
        throw InputError(path.string() + ": a " + (folder_expected ? "file" : "folder") +
                         " is in the way of the output " + (folder_expected ? "folder" : "file") +
                         " of that name; move it away or choose another output folder");
      }
    }
    fs::create_directory(staging_, error);
    if (error) {
      throw InputError(dir_ + ": the output folder is not writable (" + error.message() +
                       "); choose another");
    }
  } catch (...) {
    Release();
    throw;
  }
}

void OutputSet::Recover() {
  const fs::path folder(dir_);
  const fs::path previous = folder / kPreviousName;
  if (Exists(previous)) {
    // A swap was stopped half-way. Before the marker, the earlier set was being moved aside and
    // nothing new was in; after it, every owned name in the folder is new. Either way the earlier
    // set is put back whole.
    if (Exists(previous / kAllMovedName)) {
      for (const std::string& name : owned_names_) fs::remove_all(folder / Bare(name));
    }
    for (const fs::directory_entry& entry : fs::directory_iterator(previous)) {
      const std::string name = entry.path().filename().string();
      if (name == kAllMovedName) continue;
      fs::remove_all(folder / name);
      fs::rename(entry.path(), folder / name);
    }
    fs::remove_all(previous);
    recovery_note_ =
        "an earlier run was stopped while swapping its outputs in; the outputs before it were "
        "restored";
  }
  fs::remove_all(staging_);
  // Hidden temporaries of earlier versions, which wrote each output beside its final name.
  for (const std::string& name : owned_names_) {
    fs::remove(folder / ("." + Bare(name) + ".tmp"));
  }
  fs::remove(folder / ".stillmap_write_probe.tmp");
}

void OutputSet::Release() {
  std::error_code ignored;
  if (!committed_ && created_dir_) fs::remove(fs::path(dir_) / kLockName, ignored);
  if (lock_fd_ >= 0) ::close(lock_fd_);
  lock_fd_ = -1;
  if (!committed_ && created_dir_) fs::remove(dir_, ignored);  // only when empty
}

OutputSet::~OutputSet() {
  std::error_code ignored;
  if (!committed_) fs::remove_all(staging_, ignored);
  Release();
}

bool OutputSet::IsInternalName(const std::string& filename) {
  return filename == kLockName || filename == kStagingName || filename == kPreviousName;
}

std::vector<std::string> OutputSet::ForeignNames() const {
  std::vector<std::string> foreign;
  std::error_code error;
  for (const fs::directory_entry& entry : fs::directory_iterator(dir_, error)) {
    const std::string name = entry.path().filename().string();
    const bool owned =
        std::find(owned_names_.begin(), owned_names_.end(), name) != owned_names_.end() ||
        std::find(owned_names_.begin(), owned_names_.end(), name + "/") != owned_names_.end();
    if (!owned && !IsInternalName(name)) foreign.push_back(name);
  }
  std::sort(foreign.begin(), foreign.end());
  return foreign;
}

std::string OutputSet::TemporaryPath(const std::string& name) {
  const fs::path path = fs::path(staging_) / name;
  fs::create_directories(path.parent_path());
  return path.string();
}

std::string OutputSet::FinalPath(const std::string& name) const {
  return (fs::path(dir_) / name).string();
}

void OutputSet::Commit() {
  const fs::path folder(dir_);
  const fs::path previous = folder / kPreviousName;
  std::vector<std::string> staged;
  for (const fs::directory_entry& entry : fs::directory_iterator(staging_)) {
    staged.push_back(entry.path().filename().string());
    const bool owned =
        std::any_of(owned_names_.begin(), owned_names_.end(),
                    [&](const std::string& name) { return Bare(name) == staged.back(); });
    if (!owned) throw std::logic_error("OutputSet: '" + staged.back() + "' is not an owned name");
  }
  std::vector<std::string> moved_aside, moved_in;
  try {
    fs::create_directory(previous);
    for (const std::string& name : owned_names_) {
      if (!Exists(folder / Bare(name))) continue;
      fs::rename(folder / Bare(name), previous / Bare(name));
      moved_aside.push_back(Bare(name));
    }
    std::ofstream marker(previous / kAllMovedName);
    if (!marker.flush()) {
      throw fs::filesystem_error("cannot write a marker", previous,
                                 std::make_error_code(std::errc::io_error));
    }
    for (const std::string& name : staged) {
      fs::rename(fs::path(staging_) / name, folder / name);
      moved_in.push_back(name);
    }
  } catch (const fs::filesystem_error& e) {
    std::error_code ignored;
    for (const std::string& name : moved_in) {
      fs::rename(folder / name, fs::path(staging_) / name, ignored);
    }
    for (const std::string& name : moved_aside) {
      fs::rename(previous / name, folder / name, ignored);
    }
    fs::remove_all(previous, ignored);
    throw std::runtime_error(dir_ + ": could not swap the new outputs in (" + e.code().message() +
                             ": " + e.path1().string() + "); the earlier outputs are unchanged");
  }
  committed_ = true;
  std::error_code ignored;
  fs::remove_all(previous, ignored);
  fs::remove_all(staging_, ignored);
}

}  // namespace stillmap
