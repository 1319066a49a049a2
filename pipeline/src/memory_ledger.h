// Where a build's memory goes. A watcher thread reads the process's resident memory every 50 ms
// and keeps the highest reading, its own or a sample's, with the phase the build was in (Phase);
// at chosen points the build also samples what each owner holds (Sample), and the sample taken at
// the highest resident memory is the one report.json breaks down (timing.memory), with the pages
// mapped from files (code and libraries) read just before it. The rest of the resident memory
// is stacks, the allocator's free lists and what no owner counts.
#pragma once

#include <condition_variable>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "stillmap/pipeline/build_result.h"

namespace stillmap {

// The fixed owner of the detector's models (freed once the frames are masked).
inline constexpr const char* kDetectorMemoryOwner = "detector_models";
// The owner every sample adds: the resident pages mapped from files (the program's code and its
// libraries; FileBackedMemoryMib).
inline constexpr const char* kCodeMemoryOwner = "code_and_libraries";

class MemoryLedger {
 public:
  MemoryLedger();
  ~MemoryLedger();
  MemoryLedger(const MemoryLedger&) = delete;
  MemoryLedger& operator=(const MemoryLedger&) = delete;

  // The phase the build enters (e.g. "frame loop", "writing the map files").
  void Phase(const std::string& name);
  // Owners counted once and added to every sample (the detector's models, measured as the
  // resident memory their loading took).
  void AddFixed(const std::string& name, double mib);
  // A fixed owner was freed: the samples from here on leave it out.
  void DropFixed(const std::string& name);
  // The resident memory now and what each owner holds now [bytes], taken `when` (e.g. "frame
  // loop, frame at 312.4 s"); the fixed owners and kCodeMemoryOwner are added to them.
  void Sample(const std::string& when, const std::vector<std::pair<std::string, size_t>>& owners);
  // Stops the watcher and returns what it and the samples found.
  MemoryFigures Finish();

 private:
  void Watch();
  // Keeps `resident` [MiB] as the highest reading if it is (mutex_ held).
  void KeepHighestReading(double resident);
  void Stop();  // ends the watcher (once; later calls do nothing)

  std::mutex mutex_;  // guards the phase, the watcher's figures and stopping_
  std::condition_variable wake_;
  bool stopping_ = false;
  std::string phase_;
  std::vector<MemoryOwner> fixed_;
  MemoryFigures figures_;
  std::thread watcher_;  // last: starts after the rest is made
};

}  // namespace stillmap
