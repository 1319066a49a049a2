// TUM file lists (rgb.txt, depth.txt, masks.txt) and timestamp association.
#pragma once

#include <cstddef>
#include <string>
#include <utility>
#include <vector>

namespace stillmap {

// One line of a TUM file list: "timestamp path", path relative to the sequence folder.
struct StampedPath {
  double time = 0.0;  // [s]
  std::string path;   // as written in the list
  int line = 0;       // 1-based line in the list, for error messages
};

// Reads a TUM file list. Lines starting with '#' and blank lines are skipped. Throws InputError
// naming the file and line for a malformed line, a missing or empty list, and for timestamps that
// are not strictly increasing (an unsorted or duplicated list is refused, not silently sorted: it
// usually means two recordings were mixed).
std::vector<StampedPath> ReadFileList(const std::string& path);

// Associates two sorted timestamp lists as the TUM benchmark's associate.py does: every pair
// closer than `max_difference` is a candidate, candidates are taken by increasing time difference,
// and each timestamp is used at most once. Returns (index in a, index in b), sorted by a.
std::vector<std::pair<size_t, size_t>> AssociateTimestamps(const std::vector<double>& a,
                                                           const std::vector<double>& b,
                                                           double max_difference);

// Index of the element of the sorted, non-empty `times` nearest to `time`.
size_t FindClosestIndex(const std::vector<double>& times, double time);

// The lines of a text file (`what` names it in messages), ended by LF, CRLF or a lone CR. Throws
// InputError naming the file and line when it is missing or holds a NUL or other control byte (a
// binary or damaged file), so that no caller echoes raw bytes.
std::vector<std::string> ReadTextLines(const std::string& path, const std::string& what);

// Splits a line on spaces, tabs and commas (the TUM tools accept all three).
std::vector<std::string> SplitFields(const std::string& line);

// Parses a whole-string double; false when the text is not a finite number.
bool ParseFiniteDouble(const std::string& text, double* value);

}  // namespace stillmap
