// Exceptions that separate bad input (exit status 2) from a run that failed (exit status 1).
#pragma once

#include <stdexcept>
#include <string>

namespace stillmap {

// Bad input at the edges: a missing file, a malformed line, an impossible parameter. The message
// names the file (and line) and says what was expected, so the command line can print it as is.
class InputError : public std::runtime_error {
 public:
  explicit InputError(const std::string& message) : std::runtime_error(message) {}
};

// Formats "FILE:LINE: what" (LINE omitted when 0), the prefix every format error uses.
std::string WhereInFile(const std::string& path, int line);

// `text` as a message may quote it: control and non-ASCII bytes as \xNN, cut after `max_chars`
// with "...", so that a binary file's bytes never reach the terminal raw.
std::string Quoted(const std::string& text, size_t max_chars = 80);

// "PATH: could not write WHAT: REASON" for a write that just failed, the reason read from errno
// in the user's words: the disk is full, the quota is used up, the file system is read-only,
// permission, an I/O error; else the system's own description.
std::string WriteFailure(const std::string& path, const std::string& what);

}  // namespace stillmap
