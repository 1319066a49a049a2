// Per-stage timings of the mapping hot paths on one 640x480 frame: depth smoothing,
// back-projection, voxel insertion and OctoMap insertion. Real data when ../shared/data (or
// $STILLMAP_DATA) has tum_fr3_teddy_200, else a synthetic plane.
//   build/tests/benchmarks/stillmap_mapping_benchmark
#include <benchmark/benchmark.h>

#include <random>

#include "stillmap/io/sequence.h"
#include "stillmap/mapping/back_projection.h"
#include "stillmap/mapping/occupancy_map.h"
#include "stillmap/mapping/voxel_cloud.h"
#include "test_util.h"

namespace stillmap {
namespace {

struct Input {
  Camera camera;
  cv::Mat color, depth_m;
  Eigen::Isometry3f world_from_camera = Eigen::Isometry3f::Identity();
};

const Input& GetInput() {
  static const Input kInput = [] {
    Input in;
    if (const auto dir = testing::SharedSequence("tum_fr3_teddy_200")) {
      in.camera = ResolveCamera(*dir, {});
      const Sequence sequence = Sequence::Open(*dir, in.camera);
      const Frame frame = sequence.LoadFrame(50);
      in.color = frame.color;
      in.depth_m = frame.depth_m;
      in.world_from_camera = sequence.groundtruth()->Interpolate(frame.time, 0.1)->cast<float>();
    } else {
      in.camera = CameraPreset("ros_default");
      in.color = cv::Mat(480, 640, CV_8UC3, cv::Scalar(90, 120, 150));
      in.depth_m = cv::Mat(480, 640, CV_32FC1);
      std::mt19937 rng(1);
      std::normal_distribution<float> noise(0.0f, 0.01f);
      for (int v = 0; v < 480; ++v) {
        for (int u = 0; u < 640; ++u) in.depth_m.at<float>(v, u) = 2.0f + 0.002f * u + noise(rng);
      }
    }
    return in;
  }();
  return kInput;
}

void BM_SmoothDepth(benchmark::State& state) {  // NOLINT(readability-identifier-naming)
  const Input& in = GetInput();
  cv::Mat smoothed;
  for (auto _ : state) {
    SmoothDepth(in.depth_m, static_cast<int>(state.range(0)), &smoothed);
    benchmark::DoNotOptimize(smoothed.data);
  }
}
BENCHMARK(BM_SmoothDepth)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond);

void BM_BackProject(benchmark::State& state) {  // NOLINT(readability-identifier-naming)
  const Input& in = GetInput();
  BackProjectionOptions options;
  options.smoothing_radius = static_cast<int>(state.range(0));
  const DepthBackProjector projector(in.camera, options);
  ColoredPoints points;
  for (auto _ : state) {
    points.Clear();
    projector.BackProject(in.depth_m, in.color, cv::Mat(), in.world_from_camera, &points);
    benchmark::DoNotOptimize(points.positions.data());
  }
  state.counters["points"] = static_cast<double>(points.size());
}
BENCHMARK(BM_BackProject)->Arg(0)->Arg(2)->Unit(benchmark::kMillisecond);

// The frame's points, unsmoothed, in the world frame.
ColoredPoints FramePoints() {
  const Input& in = GetInput();
  BackProjectionOptions options;
  options.smoothing_radius = 0;
  ColoredPoints points;
  DepthBackProjector(in.camera, options)
      .BackProject(in.depth_m, in.color, cv::Mat(), in.world_from_camera, &points);
  return points;
}

// Inserting the same frame again: the voxels exist already, as for most points of a sequence.
void BM_VoxelInsert(benchmark::State& state) {  // NOLINT(readability-identifier-naming)
  const ColoredPoints points = FramePoints();
  VoxelCloud cloud;
  for (auto _ : state) cloud.Insert(points);
  state.counters["points"] = static_cast<double>(points.size());
}
BENCHMARK(BM_VoxelInsert)->Unit(benchmark::kMillisecond);

// Inserting the frame 10 cm further on each time: most voxels are new and the cloud grows to
// millions (a floor's 12 M at 1 cm do not fit any cache), so the index doubles on the way.
void BM_VoxelInsertGrowing(benchmark::State& state) {  // NOLINT(readability-identifier-naming)
  ColoredPoints points = FramePoints();
  VoxelCloud cloud;
  for (auto _ : state) {
    for (Eigen::Vector3f& p : points.positions) p.x() += 0.1f;
    cloud.Insert(points);
  }
  state.counters["points"] = static_cast<double>(points.size());
  state.counters["voxels"] = static_cast<double>(cloud.size());
  state.counters["table_MiB"] = static_cast<double>(cloud.MemoryBytes()) / (1024.0 * 1024.0);
}
BENCHMARK(BM_VoxelInsertGrowing)->Iterations(300)->Unit(benchmark::kMillisecond);

// One visit of every voxel in key order, as each step of the map cleaning makes, over a cloud
// of millions (the frame 10 cm further on, 300 times over): sorted and merged afresh (0), or by
// the order a removal made and kept (1).
void BM_VoxelVisit(benchmark::State& state) {  // NOLINT(readability-identifier-naming)
  ColoredPoints points = FramePoints();
  VoxelCloud cloud;
  for (int k = 0; k < 300; ++k) {
    for (Eigen::Vector3f& p : points.positions) p.x() += 0.1f;
    cloud.Insert(points);
  }
  if (state.range(0) == 1) cloud.RemoveIf([](const VoxelPoint&) { return false; });
  for (auto _ : state) {
    double sum = 0.0;
    cloud.ForEachPoint([&sum](const VoxelPoint& point) { sum += point.position.x(); });
    benchmark::DoNotOptimize(sum);
  }
  state.counters["voxels"] = static_cast<double>(cloud.size());
}
BENCHMARK(BM_VoxelVisit)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

void BM_OctomapInsert(benchmark::State& state) {  // NOLINT(readability-identifier-naming)
  const Input& in = GetInput();
  ColoredPoints points;
  DepthBackProjector(in.camera, {})
      .BackProject(in.depth_m, in.color, cv::Mat(), in.world_from_camera, &points);
  OccupancyMap map;
  for (auto _ : state) map.InsertScan(points.positions, in.world_from_camera.translation());
}
BENCHMARK(BM_OctomapInsert)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace stillmap

BENCHMARK_MAIN();
