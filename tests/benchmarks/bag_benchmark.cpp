// Reading recorded bags on one core: frame pairs decoded per second (colour BGR and depth in
// metres, as the build's reader thread gives them), and the one scan that opens a bag. The bag is
// $STILLMAP_BAG when set (e.g. a whole sequence written by ../shared/tools/make-bags --format mcap
// --compression zstd --colour jpeg), else the shared teddy_realsense.mcap (zstd chunks, JPEG
// colour, 16UC1 depth).
//   build/tests/benchmarks/stillmap_bag_benchmark
#include <benchmark/benchmark.h>

#include <cstdlib>

#include "stillmap/io/sequence.h"
#include "test_util.h"

namespace stillmap {
namespace {

std::optional<std::string> BagPath() {
  if (const char* bag = std::getenv("STILLMAP_BAG")) return std::string(bag);
  return testing::SharedBag("teddy_realsense.mcap");
}

void BM_DecodeBagPairs(benchmark::State& state) {  // NOLINT(readability-identifier-naming)
  const std::optional<std::string> path = BagPath();
  if (!path) {
    state.SkipWithError("no bag: set STILLMAP_BAG or share ../shared/data/bags");
    return;
  }
  const Sequence sequence = Sequence::OpenBag(*path, {});
  size_t index = 0;
  for (auto _ : state) {
    const Frame frame = sequence.LoadFrame(index);
    benchmark::DoNotOptimize(frame.depth_m.data);
    index = (index + 1) % sequence.frames().size();
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations()));
  state.SetLabel(std::to_string(sequence.frames().size()) + " pairs");
}
BENCHMARK(BM_DecodeBagPairs)->Unit(benchmark::kMillisecond);

void BM_OpenBag(benchmark::State& state) {  // NOLINT(readability-identifier-naming)
  const std::optional<std::string> path = BagPath();
  if (!path) {
    state.SkipWithError("no bag: set STILLMAP_BAG or share ../shared/data/bags");
    return;
  }
  for (auto _ : state) {
    const Sequence sequence = Sequence::OpenBag(*path, {});
    benchmark::DoNotOptimize(sequence.frames().data());
  }
}
BENCHMARK(BM_OpenBag)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace stillmap

BENCHMARK_MAIN();
