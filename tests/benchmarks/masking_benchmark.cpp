// Per-stage timings of the dynamic mask on a real crowd sequence (bonn_crowd_a from
// ../shared/data, or $STILLMAP_DATA): flow corners (full against half resolution), the KLT
// pyramid, the forward-backward flow check, the depth check against three references (ground-truth
// poses), and the whole DynamicMasker per frame. Skips with a message when the sequence is absent.
//   build/tests/benchmarks/stillmap_masking_benchmark
#include <benchmark/benchmark.h>

#include <opencv2/imgproc.hpp>

#include "stillmap/io/sequence.h"
#include "stillmap/tracking/dynamic_mask.h"
#include "stillmap/tracking/flow_check.h"
#include "test_util.h"

namespace stillmap {
namespace {

constexpr size_t kFirst = 200;  // people are in view from here on
constexpr size_t kFrames = 40;

struct Input {
  bool ok = false;
  Camera camera;
  std::vector<Frame> frames;
  std::vector<cv::Mat> grays;
  std::vector<Eigen::Isometry3d> poses;  // ground truth, camera to world
};

const Input& GetInput() {
  static const Input kInput = [] {
    Input in;
    const auto dir = testing::SharedSequence("bonn_crowd_a");
    if (!dir) return in;
    in.camera = ResolveCamera(*dir, {});
    const Sequence sequence = Sequence::Open(*dir, in.camera);
    if (!sequence.groundtruth()) return in;
    for (size_t i = kFirst; i < std::min(kFirst + kFrames, sequence.frames().size()); ++i) {
      const std::optional<Eigen::Isometry3d> pose =
          sequence.groundtruth()->Interpolate(sequence.frames()[i].time, 0.1);
      if (!pose) continue;
      in.frames.push_back(sequence.LoadFrame(i));
      cv::Mat gray;
      cv::cvtColor(in.frames.back().color, gray, cv::COLOR_BGR2GRAY);
      in.grays.push_back(gray);
      in.poses.push_back(*pose);
    }
    in.ok = in.frames.size() >= 20;
    return in;
  }();
  return kInput;
}

bool Skip(benchmark::State& state, const Input& in) {
  if (in.ok) return false;
  state.SkipWithError(
      "bonn_crowd_a (with ground truth) not found in ../shared/data or $STILLMAP_DATA");
  return true;
}

// Shi-Tomasi corners for the flow check. Arg 0: at full resolution, as cv::goodFeaturesToTrack
// gives them (the former way); 1: FlowCorners, at half resolution.
void BM_FlowCorners(benchmark::State& state) {  // NOLINT(readability-identifier-naming)
  const Input& in = GetInput();
  if (Skip(state, in)) return;
  std::vector<cv::Point2f> corners;
  size_t k = 0;
  for (auto _ : state) {
    const cv::Mat& gray = in.grays[k++ % in.grays.size()];
    if (state.range(0) == 0) {
      cv::goodFeaturesToTrack(gray, corners, 400, 0.01, 8.0);
    } else {
      corners = FlowCorners(gray, 400, 8.0);
    }
    benchmark::DoNotOptimize(corners.data());
  }
  state.counters["corners"] = static_cast<double>(corners.size());
}
BENCHMARK(BM_FlowCorners)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

void BM_FlowPyramid(benchmark::State& state) {  // NOLINT(readability-identifier-naming)
  const Input& in = GetInput();
  if (Skip(state, in)) return;
  size_t k = 0;
  for (auto _ : state) {
    const FlowPyramid pyramid = BuildFlowPyramid(in.grays[k++ % in.grays.size()]);
    benchmark::DoNotOptimize(pyramid.levels.data());
  }
}
BENCHMARK(BM_FlowPyramid)->Unit(benchmark::kMillisecond);

// First argument 0: from the images (two pyramids built per check); 1: from pyramids built
// beforehand. Second: the KLT window's edge [px] (masking.flow_klt_window; 21 before issue 29).
void BM_FlowCheck(benchmark::State& state) {  // NOLINT(readability-identifier-naming)
  const Input& in = GetInput();
  if (Skip(state, in)) return;
  FlowCheckOptions options;
  options.klt_window = static_cast<int>(state.range(1));
  std::vector<FlowPyramid> pyramids;
  std::vector<std::vector<cv::Point2f>> corners;
  for (const cv::Mat& gray : in.grays) {
    pyramids.push_back(BuildFlowPyramid(gray, options));
    corners.push_back(FlowCorners(gray, 400, 8.0));
  }
  size_t k = 0, dynamic = 0;
  for (auto _ : state) {
    const size_t i = k++ % (in.grays.size() - 1);
    const FlowCheckResult result =
        state.range(0) == 0 ? CheckFlow(in.grays[i], in.grays[i + 1], corners[i], options)
                            : CheckFlow(pyramids[i], pyramids[i + 1], corners[i], options);
    dynamic = static_cast<size_t>(std::count(result.dynamic.begin(), result.dynamic.end(), 1));
  }
  state.counters["dynamic_points"] = static_cast<double>(dynamic);
}
BENCHMARK(BM_FlowCheck)->Args({0, 21})->Args({1, 21})->Args({1, 15})->Unit(benchmark::kMillisecond);

// The depth check and growth against three references 5, 10 and 15 frames back.
void BM_DepthCheckMask(benchmark::State& state) {  // NOLINT(readability-identifier-naming)
  const Input& in = GetInput();
  if (Skip(state, in)) return;
  const DynamicMaskOptions options;
  const GeometricMasker masker(in.camera, options);
  std::vector<MaskReference> references;
  for (size_t r : {0, 5, 10}) {
    MaskReference reference{in.frames[r].time, in.frames[r].depth_m, cv::Mat(), in.poses[r],
                            cv::Mat()};
    reference.nearest_depth_m = NearestStaticDepth(reference);
    references.push_back(reference);
  }
  const std::vector<const MaskReference*> pointers = {&references[2], &references[1],
                                                      &references[0]};
  size_t k = 0;
  int seeds = 0;
  for (auto _ : state) {
    const size_t i = 15 + k++ % (in.frames.size() - 15);
    const cv::Mat mask = masker.Compute(in.frames[i].depth_m, in.poses[i], pointers, {}, &seeds);
    benchmark::DoNotOptimize(mask.data);
  }
  state.counters["seed_pixels"] = seeds;
}
BENCHMARK(BM_DepthCheckMask)->Unit(benchmark::kMillisecond);

// The whole masker per frame (flow, depth check, fusion), no detector, a reference every 5th frame.
void BM_DynamicMasker(benchmark::State& state) {  // NOLINT(readability-identifier-naming)
  const Input& in = GetInput();
  if (Skip(state, in)) return;
  double share = 0.0;
  for (auto _ : state) {
    DynamicMasker masker(in.camera, DynamicMaskOptions());
    for (size_t i = 0; i < in.frames.size(); ++i) {
      const DynamicMaskResult result =
          masker.Compute(in.grays[i], in.frames[i].depth_m, in.poses[i], nullptr);
      share += result.share;
      if (i % 5 == 0) {
        masker.AddReference(
            {in.frames[i].time, in.frames[i].depth_m, result.mask, in.poses[i], cv::Mat()});
      }
    }
  }
  state.counters["mean_share"] = share / static_cast<double>(state.iterations() * in.frames.size());
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * in.frames.size()));
}
BENCHMARK(BM_DynamicMasker)->Unit(benchmark::kMillisecond)->Iterations(3)->UseRealTime();

}  // namespace
}  // namespace stillmap

BENCHMARK_MAIN();
