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
// The resident memory of the process now [MiB] (/proc/self/statm; 0 where it cannot be read).
double ResidentMemoryMib();
// Of it, the pages mapped from files (the program's code, its libraries, files it maps) and
// shared memory [MiB] (statm's third field; 0 where it cannot be read).
double FileBackedMemoryMib();
// The process's malloc: "tbbmalloc" when TBB's proxy replaced it (the stillmap binary, see
// CMakeLists.txt), else "glibc".
const char* MemoryAllocator();
// Asks the allocator to hand the memory it keeps for reuse back to the system, after a large
// structure is freed (the voxel records, the keyframe views), so that later phases do not add
// theirs on top: tbbmalloc caches freed large blocks (TBBMALLOC_CLEAN_ALL_BUFFERS empties its
// caches), glibc keeps freed pages in its arenas (malloc_trim).
void ReleaseFreedMemory();

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
