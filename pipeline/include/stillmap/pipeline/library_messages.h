// The libraries' own messages on stderr: PCL's (its RANSAC notes "Sample points too similar or
// collinear!"), OpenCV's and Ceres' (through glog). stillmap reports what they mean for a run
// itself (report.json, the summary's warnings), so to a user they are chatter: the command turns
// them off unless --verbose. Process-wide; call before any work starts.
#pragma once

namespace stillmap {

void SetLibraryMessages(bool verbose);

}  // namespace stillmap
