#include "merge_sessions.h"

#include <fmt/format.h>

#include <filesystem>
#include <set>

#include "stillmap/io/error.h"
#include "stillmap/io/input_files.h"
#include "stillmap/io/option_names.h"
#include "stillmap/pipeline/config.h"

namespace stillmap {
namespace fs = std::filesystem;

namespace {

// Throws InputError unless `dir` is a folder (a symbolic link to one included), naming what it is.
void CheckSessionFolder(const std::string& dir) {
  std::error_code error;
  const fs::file_status status = fs::status(dir, error);
  if (status.type() == fs::file_type::directory) return;
  if (status.type() == fs::file_type::not_found) {
    throw InputError(dir +
                     ": no such folder; stillmap merge takes the output folders of "
                     "stillmap build");
  }
  if (status.type() == fs::file_type::none || status.type() == fs::file_type::unknown) {
    throw InputError(dir + ": cannot open the session folder (" + StatProblem(error) + ")");
  }
  throw InputError(dir +
                   ": not a folder; stillmap merge takes the output folders of "
                   "stillmap build");
}

// The session's name: its folder's.
std::string SessionName(const std::string& dir) {
  const fs::path path = fs::path(dir).lexically_normal();
  std::string name = (path.has_filename() ? path : path.parent_path()).filename().string();
  if (name.empty() || name == "." || name == "..") {
    std::error_code error;
    name = fs::weakly_canonical(dir, error).filename().string();
  }
  return name;
}

}  // namespace

std::vector<MergeSession> OpenSessions(const std::vector<std::string>& dirs) {
  std::vector<MergeSession> sessions;
  std::set<std::string> names;
  for (const std::string& dir : dirs) {  // the folders and their names first, then the records
    CheckSessionFolder(dir);
    for (const MergeSession& earlier : sessions) {
      std::error_code error;
      if (fs::equivalent(earlier.dir, dir, error)) {
        throw InputError(dir + ": the same folder as " + earlier.dir +
                         " (a session merges with others, not with itself); give each session "
                         "folder once");
      }
    }
    MergeSession session;
    session.name = SessionName(dir);
    if (!names.insert(session.name).second) {
      throw InputError(dir + ": a second session named '" + session.name +
                       "' (sessions are named by their folders, and each names its "
                       "trajectory_<session>.txt); rename one of the folders");
    }
    session.dir = dir;
    sessions.push_back(std::move(session));
  }
  for (MergeSession& session : sessions) {
    const std::string record = (fs::path(session.dir) / "session.bin").string();
    if (!PathExists(record)) {
      throw InputError(
          record +
          fmt::format(": missing; the folder is not the output of a tracked stillmap build "
                      "with a session record (builds with --poses groundtruth or "
                      "{}=false write none); build the session again",
                      OptionKey(&BuildConfig::session_record)));
    }
    session.reader = std::make_unique<SessionRecordReader>(record);
    if (session.record().keyframes.empty()) {
      throw InputError(record + ": the session record holds no keyframe");
    }
    session.trajectory = Trajectory::ReadTum((fs::path(session.dir) / "trajectory.txt").string());
  }
  return sessions;
}

}  // namespace stillmap
