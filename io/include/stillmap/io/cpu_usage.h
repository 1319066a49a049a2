// CPU time for the run report: of the calling thread, of the process, and how busy each core of
// the machine was (whoever used it).
#pragma once

#include <vector>

namespace stillmap {

// CPU time (user + system) the calling thread has used [ms].
double ThreadCpuMs();
// CPU time (user + system) the whole process has used, all its threads [s].
double ProcessCpuSeconds();
// The process's peak resident memory so far [MiB].
double PeakMemoryMib();
// The process's malloc: "tbbmalloc" when TBB's proxy replaced it (the stillmap binary, see
// CMakeLists.txt), else "glibc".
const char* MemoryAllocator();

// Each core's busy and total time since boot, from /proc/stat (empty where it cannot be read).
struct CoreTimes {
  unsigned long long busy = 0, total = 0;  // clock ticks
};
std::vector<CoreTimes> ReadCoreTimes();
// The share of each core's time that was busy between two readings (0..1; empty when the
// readings do not match).
std::vector<double> CoreBusyShares(const std::vector<CoreTimes>& before,
                                   const std::vector<CoreTimes>& after);

}  // namespace stillmap
