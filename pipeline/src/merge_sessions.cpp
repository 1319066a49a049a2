#include "merge_sessions.h"

#include <filesystem>
#include <set>

#include "stillmap/io/error.h"

namespace stillmap {
namespace {

namespace fs = std::filesystem;

}  // namespace

std::vector<MergeSession> OpenSessions(const std::vector<std::string>& dirs) {
  std::vector<MergeSession> sessions;
  std::set<std::string> names;
  for (const std::string& dir : dirs) {  // the folders and their names first, then the records
    if (!fs::is_directory(dir)) {
      throw InputError(dir +
                       ": not a folder; stillmap merge takes the output folders of "
                       "stillmap build");
    }
    MergeSession session;
    const fs::path path = fs::path(dir).lexically_normal();
    session.name = (path.has_filename() ? path : path.parent_path()).filename().string();
    if (session.name.empty() || session.name == "." || session.name == "..") {
      session.name = fs::weakly_canonical(dir).filename().string();
    }
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
    if (!fs::exists(record)) {
      throw InputError(record +
                       ": missing; the folder is not the output of a tracked stillmap build "
                       "with a session record (builds with --poses groundtruth or "
                       "map.session_record=false write none); build the session again");
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
