#include "stillmap/io/cpu_usage.h"

#include <dlfcn.h>
#include <malloc.h>
#include <sys/resource.h>
#include <unistd.h>

#include <ctime>
#include <fstream>
#include <sstream>
#include <string>

namespace stillmap {

double ThreadCpuMs() {
  timespec now{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &now);
  return static_cast<double>(now.tv_sec) * 1e3 + static_cast<double>(now.tv_nsec) * 1e-6;
}

double PeakMemoryMib() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return static_cast<double>(usage.ru_maxrss) / 1024.0;  // ru_maxrss is in KiB on Linux
}

namespace {

// Field `field` (0-based: size, resident, shared, ...) of /proc/self/statm [MiB]; 0 where it
// cannot be read.
double StatmFieldMib(int field) {
  std::ifstream statm("/proc/self/statm");
  unsigned long long pages = 0;
  for (int k = 0; k <= field; ++k) {
    if (!(statm >> pages)) return 0.0;
  }
  return static_cast<double>(pages) * static_cast<double>(sysconf(_SC_PAGESIZE)) /
         (1024.0 * 1024.0);
}

}  // namespace

double ResidentMemoryMib() { return StatmFieldMib(1); }

double FileBackedMemoryMib() { return StatmFieldMib(2); }

const char* MemoryAllocator() {
  // The proxy library exports this name; nothing else does.
  return dlsym(RTLD_DEFAULT, "__TBB_malloc_proxy") != nullptr ? "tbbmalloc" : "glibc";
}

void ReleaseFreedMemory() {
  using Command = int (*)(int, void*);
  // Looked up rather than linked: the libraries and tests run on glibc's malloc.
  if (void* symbol = dlsym(RTLD_DEFAULT, "scalable_allocation_command")) {
    constexpr int kCleanAllBuffers = 0;  // TBBMALLOC_CLEAN_ALL_BUFFERS (tbb/scalable_allocator.h)
    reinterpret_cast<Command>(symbol)(kCleanAllBuffers, nullptr);
  } else {
    malloc_trim(0);
  }
}

double ProcessCpuSeconds() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  auto seconds = [](const timeval& t) {
    return static_cast<double>(t.tv_sec) + static_cast<double>(t.tv_usec) * 1e-6;
  };
  return seconds(usage.ru_utime) + seconds(usage.ru_stime);
}

std::vector<CoreTimes> ReadCoreTimes() {
  std::vector<CoreTimes> cores;
  std::ifstream stat("/proc/stat");
  std::string line;
  while (std::getline(stat, line)) {
    // "cpuN user nice system idle iowait irq softirq steal ...": idle and iowait are not busy.
    if (line.compare(0, 3, "cpu") != 0 || line.size() < 4 || line[3] < '0' || line[3] > '9') {
      continue;
    }
    std::istringstream fields(line.substr(line.find(' ')));
    CoreTimes core;
    unsigned long long value = 0;
    for (int k = 0; k < 8 && fields >> value; ++k) {
      core.total += value;
      if (k != 3 && k != 4) core.busy += value;
    }
    cores.push_back(core);
  }
  return cores;
}

std::vector<double> CoreBusyShares(const std::vector<CoreTimes>& before,
                                   const std::vector<CoreTimes>& after) {
  std::vector<double> shares;
  if (before.size() != after.size()) return shares;
  for (size_t k = 0; k < before.size(); ++k) {
    const double total = static_cast<double>(after[k].total - before[k].total);
    const double busy = static_cast<double>(after[k].busy - before[k].busy);
    shares.push_back(total > 0.0 ? busy / total : 0.0);
  }
  return shares;
}

}  // namespace stillmap
