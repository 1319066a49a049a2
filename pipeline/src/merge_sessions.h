// The sessions of a merge: each build's session record and trajectory, read and checked.
#pragma once

#include <string>
#include <vector>

#include "stillmap/io/session_record.h"
#include "stillmap/io/trajectory.h"

namespace stillmap {

struct MergeSession {
  std::string name;  // the session folder's name (trajectory_<name>.txt)
  std::string dir;
  std::unique_ptr<SessionRecordReader> reader;  // the record; images on request
  Trajectory trajectory;                        // trajectory.txt, in the session's map frame
  const SessionRecord& record() const { return reader->record(); }
};

// Opens each build output folder of `dirs`. Throws InputError naming the folder or file when one
// is missing, holds no session record (a build with --poses groundtruth, or before records
// existed) or names a session twice.
std::vector<MergeSession> OpenSessions(const std::vector<std::string>& dirs);

}  // namespace stillmap
