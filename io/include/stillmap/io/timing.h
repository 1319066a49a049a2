// Wall-clock durations for the run report's timings.
#pragma once

#include <chrono>

namespace stillmap {

// Milliseconds (seconds) of wall time since `start` (steady clock).
inline double MillisecondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
      .count();
}
inline double SecondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace stillmap
