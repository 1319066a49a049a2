#include "stillmap/io/file_list.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <iomanip>
#include <sstream>
#include <tuple>

#include "stillmap/io/error.h"
#include "stillmap/io/input_files.h"

namespace stillmap {

std::vector<std::string> SplitFields(const std::string& line) {
  std::vector<std::string> fields;
  std::string current;
  for (char c : line) {
    if (c == ' ' || c == '\t' || c == ',' || c == '\r') {
      if (!current.empty()) fields.push_back(current);
      current.clear();
    } else {
      current.push_back(c);
    }
  }
  if (!current.empty()) fields.push_back(current);
  return fields;
}

bool ParseFiniteDouble(const std::string& text, double* value) {
  if (text.empty()) return false;
  char* end = nullptr;
  const double parsed = std::strtod(text.c_str(), &end);
  if (end != text.c_str() + text.size() || !std::isfinite(parsed)) return false;
  *value = parsed;
  return true;
}

std::vector<std::string> ReadTextLines(const std::string& path, const std::string& what) {
  CheckInputFile(path, what);
  std::ifstream in(path, std::ios::binary);
  std::stringstream text;
  text << in.rdbuf();
  if (!in) throw InputError(path + ": cannot read the " + what);
  std::vector<std::string> lines(1);
  const std::string bytes = text.str();
  for (size_t i = 0; i < bytes.size(); ++i) {
    const char c = bytes[i];
    if (c == '\n' || c == '\r') {
      if (c == '\r' && i + 1 < bytes.size() && bytes[i + 1] == '\n') ++i;  // CRLF
      lines.emplace_back();
    } else if (c == '\0' || (static_cast<unsigned char>(c) < 0x20 && c != '\t')) {
      throw InputError(WhereInFile(path, static_cast<int>(lines.size())) + ": the " + what +
                       " holds a control byte (" + Quoted(std::string(1, c)) +
                       ") and is not a text file; is it damaged or a binary file?");
    } else {
      lines.back() += c;
    }
  }
  if (lines.back().empty()) lines.pop_back();
  return lines;
}

std::vector<StampedPath> ReadFileList(const std::string& path) {
  const std::vector<std::string> lines =
      ReadTextLines(path, "file list (does the sequence have it?)");
  std::vector<StampedPath> entries;
  int line_number = 0;
  for (const std::string& line : lines) {
    ++line_number;
    const std::vector<std::string> fields = SplitFields(line);
    if (fields.empty() || fields[0][0] == '#') continue;
    StampedPath entry;
    entry.line = line_number;
    if (fields.size() != 2 || !ParseFiniteDouble(fields[0], &entry.time)) {
      throw InputError(WhereInFile(path, line_number) +
                       ": expected 'timestamp path' (a number and a file name), got '" +
                       Quoted(line) + "'");
    }
    entry.path = fields[1];
    if (!entries.empty() && entry.time <= entries.back().time) {
      std::ostringstream message;
      message << std::setprecision(16) << WhereInFile(path, line_number) << ": timestamp "
              << entry.time << (entry.time == entries.back().time ? " repeats" : " is earlier than")
              << " line " << entries.back().line << "'s " << entries.back().time
              << "; timestamps must strictly increase (remove duplicates, sort with sort -n)";
      throw InputError(message.str());
    }
    entries.push_back(entry);
  }
  if (entries.empty()) throw InputError(path + ": the file list names no images");
  return entries;
}

std::vector<std::pair<size_t, size_t>> AssociateTimestamps(const std::vector<double>& a,
                                                           const std::vector<double>& b,
                                                           double max_difference) {
  // Candidates from a sliding window over both sorted lists: O(n + candidates).
  std::vector<std::tuple<double, size_t, size_t>> candidates;
  size_t b_begin = 0;
  for (size_t i = 0; i < a.size(); ++i) {
    while (b_begin < b.size() && b[b_begin] < a[i] - max_difference) ++b_begin;
    for (size_t j = b_begin; j < b.size() && b[j] < a[i] + max_difference; ++j) {
      const double difference = std::abs(a[i] - b[j]);
      if (difference < max_difference) candidates.emplace_back(difference, i, j);
    }
  }
  std::sort(candidates.begin(), candidates.end());
  std::vector<bool> a_used(a.size(), false);
  std::vector<bool> b_used(b.size(), false);
  std::vector<std::pair<size_t, size_t>> matches;
  for (const auto& [difference, i, j] : candidates) {
    if (a_used[i] || b_used[j]) continue;
    a_used[i] = b_used[j] = true;
    matches.emplace_back(i, j);
  }
  std::sort(matches.begin(), matches.end());
  return matches;
}

size_t FindClosestIndex(const std::vector<double>& times, double time) {
  const auto upper = std::lower_bound(times.begin(), times.end(), time);
  if (upper == times.begin()) return 0;
  if (upper == times.end()) return times.size() - 1;
  const size_t index = static_cast<size_t>(upper - times.begin());
  return (time - times[index - 1] <= times[index] - time) ? index - 1 : index;
}

}  // namespace stillmap
