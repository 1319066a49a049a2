#include "memory_ledger.h"

#include <algorithm>
#include <chrono>

#include "stillmap/io/cpu_usage.h"

namespace stillmap {
namespace {

constexpr double kMib = 1024.0 * 1024.0;

void KeepLargest(const MemoryOwner& owner, std::vector<MemoryOwner>* largest) {
  const auto it = std::find_if(largest->begin(), largest->end(),
                               [&](const MemoryOwner& o) { return o.name == owner.name; });
  if (it == largest->end()) {
    largest->push_back(owner);
  } else {
    it->mib = std::max(it->mib, owner.mib);
  }
}

void SortLargestFirst(std::vector<MemoryOwner>* owners) {
  std::stable_sort(owners->begin(), owners->end(),
                   [](const MemoryOwner& a, const MemoryOwner& b) { return a.mib > b.mib; });
}

}  // namespace

MemoryLedger::MemoryLedger() : watcher_([this] { Watch(); }) {}

MemoryLedger::~MemoryLedger() { Stop(); }

void MemoryLedger::Stop() {
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
  }
  wake_.notify_all();
  if (watcher_.joinable()) watcher_.join();
}

void MemoryLedger::Watch() {
  std::unique_lock<std::mutex> lock(mutex_);
  while (!stopping_) {
    KeepHighestReading(ResidentMemoryMib());
    wake_.wait_for(lock, std::chrono::milliseconds(50));
  }
}

void MemoryLedger::KeepHighestReading(double resident) {
  if (resident <= figures_.peak_watched_mib) return;
  figures_.peak_watched_mib = resident;
  figures_.peak_watched_phase = phase_;
}

void MemoryLedger::Phase(const std::string& name) {
  const std::lock_guard<std::mutex> lock(mutex_);
  phase_ = name;
}

MemoryFigures MemoryLedger::Finish() {
  Stop();
  return figures_;
}

void MemoryLedger::AddFixed(const std::string& name, double mib) {
  const std::lock_guard<std::mutex> lock(mutex_);
  fixed_.push_back({name, std::max(0.0, mib)});
}

void MemoryLedger::DropFixed(const std::string& name) {
  const std::lock_guard<std::mutex> lock(mutex_);
  fixed_.erase(std::remove_if(fixed_.begin(), fixed_.end(),
                              [&](const MemoryOwner& owner) { return owner.name == name; }),
               fixed_.end());
}

void MemoryLedger::Sample(const std::string& when,
                          const std::vector<std::pair<std::string, size_t>>& owners) {
  const std::lock_guard<std::mutex> lock(mutex_);
  std::vector<MemoryOwner> sample = fixed_;
  for (const auto& [name, bytes] : owners)
    sample.push_back({name, static_cast<double>(bytes) / kMib});
  sample.push_back({kCodeMemoryOwner, FileBackedMemoryMib()});
  for (const MemoryOwner& owner : sample) KeepLargest(owner, &figures_.largest);
  SortLargestFirst(&figures_.largest);
  ++figures_.samples;
  const double resident = ResidentMemoryMib();
  // A sample is a reading too: memory that rose after the watcher's last read is not missed.
  KeepHighestReading(resident);
  if (resident <= figures_.peak_sample_mib) return;
  figures_.peak_sample_mib = resident;
  figures_.peak_when = when;
  SortLargestFirst(&sample);
  figures_.at_peak = std::move(sample);
}

}  // namespace stillmap
