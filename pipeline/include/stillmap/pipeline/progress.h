// A one-line progress display for terminals: frames done, frames per second, time left.
#pragma once

#include <chrono>
#include <string>

namespace stillmap {

class ProgressLine {
 public:
  // `enabled` false makes every call a no-op (--quiet, or stderr not a terminal).
  ProgressLine(std::string label, size_t total, bool enabled);
  ~ProgressLine();
  // Redraws at most ~5 times per second.
  void Update(size_t done);
  // Draws the final state and ends the line.
  void Finish();

 private:
  void Draw(size_t done);

  std::string label_;
  size_t total_;
  bool enabled_;
  bool finished_ = false;
  size_t done_ = 0;
  std::chrono::steady_clock::time_point start_;
  std::chrono::steady_clock::time_point last_draw_;
};

// Whether stderr is a terminal.
bool StderrIsTerminal();

}  // namespace stillmap
