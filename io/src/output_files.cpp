#include "stillmap/io/output_files.h"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <system_error>

#include "stillmap/io/error.h"
#include "stillmap/io/input_files.h"

namespace stillmap {

namespace fs = std::filesystem;

namespace {

constexpr char kLockName[] = ".stillmap.lock";
constexpr char kStagingName[] = ".stillmap-staging";
constexpr char kLegacyPreviousName[] = ".stillmap-previous";  // versions before the record
constexpr char kSetAsideSuffix[] = ".before-stillmap";

std::string RecordName(const std::string& kind) { return ".stillmap-" + kind + "-outputs"; }
std::string JournalName(const std::string& kind) { return ".stillmap-" + kind + "-swap"; }

std::string Bare(const std::string& name) {
  return !name.empty() && name.back() == '/' ? name.substr(0, name.size() - 1) : name;
}

bool Exists(const fs::path& path) {
  std::error_code error;
  return fs::exists(fs::symlink_status(path, error));
}

bool IsRealFolder(const fs::path& path) {
  std::error_code error;
  return fs::is_directory(fs::symlink_status(path, error));
}

bool Contains(const std::vector<std::string>& sorted, const std::string& name) {
  return std::binary_search(sorted.begin(), sorted.end(), name);
}

// Whether `name` (from a record or journal, which a user could edit) is a plain relative path
// that stays inside `folder`: no empty, '.' or '..' component, and no symbolic link on the way.
bool StaysInside(const fs::path& folder, const std::string& name) {
  if (name.empty() || name.front() == '/' || name.find('\0') != std::string::npos) return false;
  fs::path at = folder;
  std::istringstream parts(name);
  std::vector<std::string> components;
  for (std::string part; std::getline(parts, part, '/');) components.push_back(part);
  for (size_t i = 0; i < components.size(); ++i) {
    const std::string& part = components[i];
    if (part.empty() || part == "." || part == "..") return false;
    at /= part;
    if (i + 1 < components.size() && Exists(at) && !IsRealFolder(at)) return false;
  }
  return !OutputSet::IsInternalName(components.front());
}

// The names of a record or journal file: one per line after '#' comments.
std::vector<std::string> ReadLines(const fs::path& path) {
  std::ifstream in(path);
  std::vector<std::string> lines;
  for (std::string line; std::getline(in, line);) {
    if (!line.empty() && line[0] != '#') lines.push_back(line);
  }
  return lines;
}

// Writes `text` to `path` through a new hidden file (never following a link left at either
// name) and one rename, so that the file is either the old one or the whole new one.
void WriteAtomically(const fs::path& path, const std::string& text) {
  const fs::path temporary = path.string() + ".tmp";
  ::unlink(temporary.c_str());
  const int fd =
      ::open(temporary.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0644);
  bool ok = fd >= 0 && ::write(fd, text.data(), text.size()) == static_cast<ssize_t>(text.size());
  ok = fd >= 0 && ::fsync(fd) == 0 && ok;
  if (fd >= 0) ::close(fd);
  if (!ok || ::rename(temporary.c_str(), path.c_str()) != 0) {
    const int saved = errno != 0 ? errno : EIO;
    ::unlink(temporary.c_str());
    throw fs::filesystem_error("cannot write", path,
                               std::error_code(saved, std::generic_category()));
  }
}

std::vector<std::string> RecordOf(const fs::path& folder, const std::string& kind) {
  std::vector<std::string> names;
  for (const std::string& name : ReadLines(folder / RecordName(kind))) {
    if (StaysInside(folder, name)) names.push_back(name);
  }
  std::sort(names.begin(), names.end());
  return names;
}

// Removes `name` (a file or link; never a folder's contents) and then the folders on its path
// that it leaves empty.
void RemoveRecorded(const fs::path& folder, const std::string& name) {
  std::error_code ignored;
  if (IsRealFolder(folder / name)) return;
  fs::remove(folder / name, ignored);
  for (fs::path parent = fs::path(name).parent_path(); !parent.empty();
       parent = parent.parent_path()) {
    if (!fs::remove(folder / parent, ignored)) break;  // not empty
  }
}

// One swap, as the journal holds it: files to rename aside first, then the files staged.
struct Journal {
  std::vector<OutputSet::SetAside> set_aside;
  std::vector<std::string> written;  // sorted
};

std::string JournalText(const Journal& journal) {
  std::string text =
      "# stillmap: a swap of new outputs into this folder, completed by the next stillmap run\n";
  for (const OutputSet::SetAside& entry : journal.set_aside) {
    text += "set-aside\t" + entry.name + "\t" + entry.kept_as + "\n";
  }
  for (const std::string& name : journal.written) text += "write\t" + name + "\n";
  return text;
}

Journal ReadJournal(const fs::path& folder, const std::string& kind) {
  Journal journal;
  for (const std::string& line : ReadLines(folder / JournalName(kind))) {
    std::vector<std::string> fields;
    std::istringstream in(line);
    for (std::string field; std::getline(in, field, '\t');) fields.push_back(field);
    if (fields.size() == 3 && fields[0] == "set-aside" && StaysInside(folder, fields[1]) &&
        StaysInside(folder, fields[2])) {
      journal.set_aside.push_back({fields[1], fields[2]});
    } else if (fields.size() == 2 && fields[0] == "write" && StaysInside(folder, fields[1])) {
      journal.written.push_back(fields[1]);
    }
  }
  std::sort(journal.written.begin(), journal.written.end());
  return journal;
}

// Carries out the journal of `kind` in `folder`. Every step can be repeated: a step already done
// finds nothing left to do, so a run killed here is completed by the next. Returns false when
// there is no journal. Throws fs::filesystem_error when a rename fails.
bool RollForward(const fs::path& folder, const std::string& kind) {
  if (!Exists(folder / JournalName(kind))) return false;
  const Journal journal = ReadJournal(folder, kind);
  const fs::path staging = folder / kStagingName;
  for (const OutputSet::SetAside& entry : journal.set_aside) {
    if (Exists(staging / entry.name) && Exists(folder / entry.name) &&
        !Exists(folder / entry.kept_as)) {
      fs::rename(folder / entry.name, folder / entry.kept_as);
    }
  }
  for (const std::string& name : journal.written) {
    if (!Exists(staging / name)) continue;  // moved in before
    fs::create_directories((folder / name).parent_path());
    fs::rename(staging / name, folder / name);
  }
  for (const std::string& name : RecordOf(folder, kind)) {
    if (!Contains(journal.written, name)) RemoveRecorded(folder, name);
  }
  std::string record = "# stillmap " + kind +
                       ": the files its last run wrote here; the next run replaces or removes "
                       "these and nothing else\n";
  for (const std::string& name : journal.written) record += name + "\n";
  WriteAtomically(folder / RecordName(kind), record);
  fs::remove(folder / JournalName(kind));
  std::error_code ignored;
  fs::remove_all(staging, ignored);
  return true;
}

// Opens and locks the folder's lock file without following a link at its name. Returns the
// descriptor, or -1 when another run holds the lock. Throws InputError when it cannot.
int LockFolder(const std::string& dir) {
  const std::string lock_path = (fs::path(dir) / kLockName).string();
  const int fd = ::open(lock_path.c_str(), O_RDWR | O_CREAT | O_NOFOLLOW | O_CLOEXEC, 0644);
  struct stat info {};
  if (fd < 0 || ::fstat(fd, &info) != 0 || !S_ISREG(info.st_mode)) {
    const bool link = fd < 0 && errno == ELOOP;
    const std::string reason = std::strerror(errno);
    if (fd >= 0) ::close(fd);
    if (link) {
      throw InputError(lock_path +
                       ": is a symbolic link, which stillmap never makes; remove it (stillmap "
                       "will not write through it)");
    }
    throw InputError(lock_path + ": cannot open the output folder's lock (" +
                     (fd >= 0 ? std::string("not a regular file") : reason) +
                     "); remove it or choose another output folder");
  }
  if (::flock(fd, LOCK_EX | LOCK_NB) != 0) {
    ::close(fd);
    return -1;
  }
  return fd;
}

std::string ReadPid(const std::string& lock_path) {
  std::ifstream in(lock_path);
  std::string pid;
  in >> pid;
  return pid.empty() ? std::string() : " (process " + pid + ")";
}

constexpr char kRecoveredNote[] =
    "an earlier run was stopped while swapping its outputs in; the swap was completed";

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

std::string RecoverOutputFolder(const std::string& dir, const std::string& kind) {
  try {
    if (!IsRealFolder(dir) || !Exists(fs::path(dir) / JournalName(kind))) return "";
    const int fd = LockFolder(dir);
    if (fd < 0) return "";
    bool done = false;
    try {
      done = RollForward(dir, kind);
    } catch (const std::exception&) {
    }
    ::close(fd);
    return done ? kRecoveredNote : "";
  } catch (const std::exception&) {
    return "";
  }
}

OutputSet::OutputSet(std::string dir, std::string kind, std::vector<std::string> owned_names)
    : dir_(std::move(dir)), kind_(std::move(kind)), owned_names_(std::move(owned_names)) {
  const fs::path folder(dir_);
  std::error_code error;
  const bool existed = fs::exists(folder, error);
  if (error) {
    throw InputError(dir_ + ": cannot use the output folder (" + StatProblem(error) +
                     "); choose another");
  }
  fs::create_directories(folder, error);
  if (error || !fs::is_directory(folder)) {
    throw InputError(dir_ + ": cannot create the output folder (" +
                     (error ? StatProblem(error) : std::string("a file has that name")) +
                     "); choose another");
  }
  created_dir_ = !existed;
  staging_ = (folder / kStagingName).string();
  try {
    lock_fd_ = LockFolder(dir_);
    if (lock_fd_ < 0) {
      throw InputError(dir_ + ": another stillmap run is writing into this folder" +
                       ReadPid((folder / kLockName).string()) +
                       "; wait for it to finish or choose another folder");
    }
    const std::string pid = std::to_string(::getpid()) + "\n";
    if (::ftruncate(lock_fd_, 0) != 0 ||
        ::write(lock_fd_, pid.data(), pid.size()) != static_cast<ssize_t>(pid.size())) {
      throw InputError(dir_ + ": the output folder is not writable; choose another");
    }
    if (RollForward(folder, kind_)) recovery_note_ = kRecoveredNote;
    if (Exists(folder / kLegacyPreviousName)) {
      recovery_note_ = (folder / kLegacyPreviousName).string() +
                       " holds files an earlier stillmap version set aside in a swap it did not "
                       "finish; nothing was taken from it: move back what you need, then delete it";
    }
    fs::remove_all(staging_);
    for (const std::string& name : owned_names_) {
      fs::remove(folder / ("." + Bare(name) + ".tmp"));  // earlier versions' temporaries
      const fs::path path = folder / Bare(name);
      if (!Exists(path)) continue;
      const bool folder_expected = name.back() == '/';
      if (IsRealFolder(path) != folder_expected) {
        throw InputError(path.string() + ": a " + (folder_expected ? "file" : "folder") +
                         " is in the way of the output " + (folder_expected ? "folder" : "file") +
                         " of that name; move it away or choose another output folder");
      }
    }
    record_ = RecordOf(folder, kind_);
    fs::create_directory(staging_, error);
    if (error) {
      throw InputError(dir_ + ": the output folder is not writable (" + error.message() +
                       "); choose another");
    }
  } catch (const fs::filesystem_error& e) {
    Release();
    throw InputError(dir_ + ": cannot prepare the output folder (" + e.code().message() + ": " +
                     e.path1().string() + "); choose another");
  } catch (...) {
    Release();
    throw;
  }
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
  const std::string prefix = ".stillmap-";
  auto ends_with = [&](const std::string& suffix) {
    return filename.size() >= suffix.size() &&
           filename.compare(filename.size() - suffix.size(), suffix.size(), suffix) == 0;
  };
  return filename == kLockName || filename == kStagingName ||
         (filename.rfind(prefix, 0) == 0 && (ends_with("-outputs") || ends_with("-swap") ||
                                             ends_with("-outputs.tmp") || ends_with("-swap.tmp")));
}

std::vector<std::string> OutputSet::ForeignNames() const {
  std::vector<std::string> foreign;
  std::error_code error;
  for (const fs::directory_entry& entry : fs::directory_iterator(dir_, error)) {
    const std::string name = entry.path().filename().string();
    const bool file =
        std::find(owned_names_.begin(), owned_names_.end(), name) != owned_names_.end();
    const bool folder =
        std::find(owned_names_.begin(), owned_names_.end(), name + "/") != owned_names_.end();
    if (folder && IsRealFolder(entry.path())) {
      for (const fs::directory_entry& inner : fs::recursive_directory_iterator(entry, error)) {
        const std::string relative = fs::relative(inner.path(), dir_, error).string();
        if (!IsRealFolder(inner.path()) && !Contains(record_, relative)) {
          foreign.push_back(relative);
        }
      }
    } else if (!file && !folder && !IsInternalName(name)) {
      foreign.push_back(name);
    }
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

std::vector<std::string> OutputSet::StagedNames() const {
  std::vector<std::string> staged;
  for (const fs::directory_entry& entry : fs::recursive_directory_iterator(staging_)) {
    if (entry.is_directory()) continue;
    staged.push_back(fs::relative(entry.path(), staging_).string());
    const std::string top = staged.back().substr(0, staged.back().find('/'));
    const bool owned = std::any_of(owned_names_.begin(), owned_names_.end(),
                                   [&](const std::string& name) { return Bare(name) == top; });
    if (!owned) throw std::logic_error("OutputSet: '" + staged.back() + "' is not an owned name");
  }
  std::sort(staged.begin(), staged.end());
  return staged;
}

std::vector<OutputSet::SetAside> OutputSet::PlanSetAside(
    const std::vector<std::string>& also_staged) const {
  std::vector<std::string> names = StagedNames();
  names.insert(names.end(), also_staged.begin(), also_staged.end());
  std::sort(names.begin(), names.end());
  names.erase(std::unique(names.begin(), names.end()), names.end());
  const fs::path folder(dir_);
  std::vector<SetAside> plan;
  for (const std::string& name : names) {
    if (!Exists(folder / name) || Contains(record_, name)) continue;
    std::string kept_as = name + kSetAsideSuffix;
    for (int n = 2; Exists(folder / kept_as); ++n) {
      kept_as = name + kSetAsideSuffix + "-" + std::to_string(n);
    }
    plan.push_back({name, kept_as});
  }
  return plan;
}

std::vector<std::string> OutputSet::SetAsideWarnings(
    const std::vector<std::string>& also_staged) const {
  std::vector<std::string> warnings;
  for (const SetAside& entry : PlanSetAside(also_staged)) {
    warnings.push_back(FinalPath(entry.name) + " was not written by stillmap; it is kept as " +
                       FinalPath(entry.kept_as));
  }
  return warnings;
}

void OutputSet::Commit() {
  const fs::path folder(dir_);
  Journal journal;
  journal.written = StagedNames();
  journal.set_aside = PlanSetAside();
  try {
    WriteAtomically(folder / JournalName(kind_), JournalText(journal));
  } catch (const fs::filesystem_error& e) {
    throw std::runtime_error(dir_ + ": could not swap the new outputs in (" + e.code().message() +
                             ": " + e.path1().string() + "); the earlier outputs are unchanged");
  }
  try {
    RollForward(folder, kind_);
  } catch (const fs::filesystem_error& e) {
    throw std::runtime_error(dir_ + ": could not swap the new outputs in (" + e.code().message() +
                             ": " + e.path1().string() +
                             "); the next stillmap command on this folder completes the swap");
  }
  committed_ = true;
}

}  // namespace stillmap
