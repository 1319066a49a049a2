// LD_PRELOAD shim for the hostile-input tests: every rename() first waits
// STILLMAP_TEST_RENAME_DELAY_US microseconds, so that a test can kill a build inside the swap of
// its outputs (strace's syscall injection does the same but slows a threaded build 10x).
#include <dlfcn.h>
#include <unistd.h>

#include <cstdlib>

extern "C" int rename(const char* from, const char* to) {
  using Rename = int (*)(const char*, const char*);
  static const auto real = reinterpret_cast<Rename>(dlsym(RTLD_NEXT, "rename"));
  if (const char* delay = std::getenv("STILLMAP_TEST_RENAME_DELAY_US")) {
    usleep(static_cast<useconds_t>(std::atoi(delay)));
  }
  return real(from, to);
}
