#include "stillmap/pipeline/progress.h"

#include <unistd.h>

#include <cstdio>

namespace stillmap {

bool StderrIsTerminal() { return isatty(STDERR_FILENO) == 1; }

ProgressLine::ProgressLine(std::string label, size_t total, bool enabled)
    : label_(std::move(label)),
      total_(total),
      enabled_(enabled),
      start_(std::chrono::steady_clock::now()),
      last_draw_(start_) {}

ProgressLine::~ProgressLine() {
  if (enabled_ && !finished_) std::fputc('\n', stderr);
}

void ProgressLine::Update(size_t done) {
  done_ = done;
  if (!enabled_) return;
  const auto now = std::chrono::steady_clock::now();
  if (now - last_draw_ < std::chrono::milliseconds(200)) return;
  last_draw_ = now;
  Draw(done);
}

void ProgressLine::Finish() {
  if (!enabled_ || finished_) return;
  Draw(done_);
  std::fputc('\n', stderr);
  finished_ = true;
}

void ProgressLine::Draw(size_t done) {
  const double elapsed =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  const double fps = elapsed > 0.0 ? static_cast<double>(done) / elapsed : 0.0;
  const double left = fps > 0.0 ? static_cast<double>(total_ - done) / fps : 0.0;
  std::fprintf(stderr, "\r%s: %zu/%zu frames, %.1f frames/s, %.0f s left   ", label_.c_str(), done,
               total_, fps, left);
  std::fflush(stderr);
}

}  // namespace stillmap
