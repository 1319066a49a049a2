// Per-stage timings of the tracker on a real sequence (tum_fr3_teddy_200 from ../shared/data, or
// $STILLMAP_DATA): ORB extraction, descriptor matching (brute force against FLANN LSH), PnP-RANSAC,
// motion-only refinement, YOLOX-Nano detection (and its network as loaded against rewritten),
// place index queries and whole-sequence tracking. Skips with a
// message when the sequence is absent.
//   build/tests/benchmarks/stillmap_tracking_benchmark
#include <benchmark/benchmark.h>

#include <iostream>
#include <map>
#include <opencv2/dnn.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/flann.hpp>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <random>

#include "stillmap/io/sequence.h"
#include "stillmap/tracking/detector.h"
#include "stillmap/tracking/features.h"
#include "stillmap/tracking/matching.h"
#include "stillmap/tracking/place_index.h"
#include "stillmap/tracking/pose_estimation.h"
#include "stillmap/tracking/pose_refinement.h"
#include "stillmap/tracking/tracker.h"
#include "test_util.h"
#include "yolox_net.h"

namespace stillmap {
namespace {

constexpr size_t kFrames = 120;  // frames loaded for the whole-sequence benchmark

struct Input {
  bool ok = false;
  Camera camera;
  std::vector<Frame> frames;
  std::vector<cv::Mat> grays;
  FrameFeatures first, second;  // frames 0 and 3
  std::vector<cv::DMatch> matches;
  std::vector<Eigen::Vector3d> points;  // first-frame points of the matches (first camera = world)
  std::vector<Eigen::Vector2d> observations;
  std::vector<RgbdObservation> rgbd;
};

const Input& GetInput() {
  static const Input kInput = [] {
    Input in;
    const auto dir = testing::SharedSequence("tum_fr3_teddy_200");
    if (!dir) return in;
    in.camera = ResolveCamera(*dir, {});
    const Sequence sequence = Sequence::Open(*dir, in.camera);
    for (size_t i = 0; i < std::min(kFrames, sequence.frames().size()); ++i) {
      in.frames.push_back(sequence.LoadFrame(i));
      cv::Mat gray;
      cv::cvtColor(in.frames.back().color, gray, cv::COLOR_BGR2GRAY);
      in.grays.push_back(gray);
    }
    const FeatureOptions options;
    in.first = ExtractFeatures(in.grays[0], in.frames[0].depth_m, in.camera, cv::Mat(), options);
    in.second = ExtractFeatures(in.grays[3], in.frames[3].depth_m, in.camera, cv::Mat(), options);
    in.matches = MatchDescriptors(in.second.descriptors, in.first.descriptors);
    for (const cv::DMatch& match : in.matches) {
      const size_t i = static_cast<size_t>(match.trainIdx), j = static_cast<size_t>(match.queryIdx);
      if (in.first.depth_m[i] <= 0.0f) continue;
      in.points.push_back(in.first.PointInCamera(i));
      in.observations.push_back(in.second.normalized[j]);
      RgbdObservation observation;
      observation.normalized = in.second.normalized[j];
      observation.depth_m = in.second.depth_m[j];
      observation.sigma_normalized = 1.0 / in.camera.fx;
      observation.sigma_inverse_depth = 0.003;
      in.rgbd.push_back(observation);
    }
    in.ok = true;
    return in;
  }();
  return kInput;
}

bool Skip(benchmark::State& state, const Input& in) {
  if (in.ok) return false;
  state.SkipWithError("tum_fr3_teddy_200 not found in ../shared/data or $STILLMAP_DATA");
  return true;
}

void BM_ExtractFeatures(benchmark::State& state) {  // NOLINT(readability-identifier-naming)
  const Input& in = GetInput();
  if (Skip(state, in)) return;
  FeatureOptions options;
  options.max_features = static_cast<int>(state.range(0));
  size_t count = 0;
  for (auto _ : state) {
    const FrameFeatures features =
        ExtractFeatures(in.grays[10], in.frames[10].depth_m, in.camera, cv::Mat(), options);
    count = features.size();
    benchmark::DoNotOptimize(features.keypoints.data());
  }
  state.counters["features"] = static_cast<double>(count);
}
BENCHMARK(BM_ExtractFeatures)->Arg(1000)->Arg(1200)->Arg(2000)->Unit(benchmark::kMillisecond);

// Two descriptor matchers for whole-frame matching (relocalization): brute force Hamming with the
// ratio test, and FLANN's LSH index (built once per train set, as a keyframe would be).
void BM_MatchBruteForce(benchmark::State& state) {  // NOLINT(readability-identifier-naming)
  const Input& in = GetInput();
  if (Skip(state, in)) return;
  size_t count = 0;
  for (auto _ : state) {
    count = MatchDescriptors(in.second.descriptors, in.first.descriptors).size();
    benchmark::DoNotOptimize(count);
  }
  state.counters["matches"] = static_cast<double>(count);
}
BENCHMARK(BM_MatchBruteForce)->Unit(benchmark::kMillisecond);

void BM_MatchFlannLsh(benchmark::State& state) {  // NOLINT(readability-identifier-naming)
  const Input& in = GetInput();
  if (Skip(state, in)) return;
  size_t count = 0;
  for (auto _ : state) {
    cv::FlannBasedMatcher matcher(cv::makePtr<cv::flann::LshIndexParams>(12, 20, 2),
                                  cv::makePtr<cv::flann::SearchParams>(32));
    std::vector<std::vector<cv::DMatch>> knn;
    matcher.knnMatch(in.second.descriptors, in.first.descriptors, knn, 2);
    count = 0;
    for (const auto& pair : knn) {
      if (pair.size() == 2 && pair[0].distance < 0.8f * pair[1].distance) ++count;
    }
    benchmark::DoNotOptimize(count);
  }
  state.counters["matches"] = static_cast<double>(count);
}
BENCHMARK(BM_MatchFlannLsh)->Unit(benchmark::kMillisecond);

void BM_PnpRansac(benchmark::State& state) {  // NOLINT(readability-identifier-naming)
  const Input& in = GetInput();
  if (Skip(state, in)) return;
  size_t inliers = 0;
  for (auto _ : state) {
    const PoseResult result = EstimatePosePnp(in.points, in.observations);
    inliers = result.inliers.size();
    benchmark::DoNotOptimize(result.camera_from_world);
  }
  state.counters["correspondences"] = static_cast<double>(in.points.size());
  state.counters["inliers"] = static_cast<double>(inliers);
}
BENCHMARK(BM_PnpRansac)->Unit(benchmark::kMillisecond);

void BM_RefinePose(benchmark::State& state) {  // NOLINT(readability-identifier-naming)
  const Input& in = GetInput();
  if (Skip(state, in)) return;
  const PoseResult initial = EstimatePosePnp(in.points, in.observations);
  for (auto _ : state) {
    const PoseResult result = RefinePose(initial.camera_from_world, in.points, in.rgbd);
    benchmark::DoNotOptimize(result.camera_from_world);
  }
  state.counters["correspondences"] = static_cast<double>(in.points.size());
}
BENCHMARK(BM_RefinePose)->Unit(benchmark::kMillisecond);

// The shared models folder holding yolox_nano/ (nothing, and the benchmark skipped, without).
std::optional<std::string> YoloxModels(benchmark::State& state) {
  auto models = testing::SharedModels("yolox_nano");
  if (!models) state.SkipWithError("yolox_nano not found in ../shared/models or $STILLMAP_MODELS");
  return models;
}

// A detector's whole Detect on a teddy frame: pre-processing, forward, decoding, NMS.
template <typename Make>
void TimeDetect(benchmark::State& state, const std::optional<std::string>& models, Make make) {
  const Input& in = GetInput();
  if (Skip(state, in) || !models) return;
  const std::unique_ptr<Detector> detector = make(*models, MotionLevelTable::Default());
  size_t count = 0;
  for (auto _ : state) {
    count = detector->Detect(in.frames[10].color).size();
    benchmark::DoNotOptimize(count);
  }
  state.counters["detections"] = static_cast<double>(count);
}

// YOLOX-Nano at its 416x320 letterbox.
void BM_YoloxDetect(benchmark::State& state) {  // NOLINT(readability-identifier-naming)
  TimeDetect(state, YoloxModels(state), [](const std::string& folder, const MotionLevelTable& l) {
    return MakeYoloxDetector(folder, l);
  });
}
BENCHMARK(BM_YoloxDetect)->Unit(benchmark::kMillisecond);

// Yolo-Fastest 1.1 (the default detector since issue 29) at 320x256, without (arg 0) and with
// (arg 1, the default) its coarse 160x128 pass.
void BM_FastestDetect(benchmark::State& state) {  // NOLINT(readability-identifier-naming)
  const auto models = testing::SharedModels("yolo_fastest_1.1");
  if (!models) state.SkipWithError("yolo_fastest_1.1 not found in ../shared/models");
  FastestOptions options;
  if (state.range(0) == 0) options.coarse_input_width = options.coarse_input_height = 0;
  TimeDetect(state, models, [&options](const std::string& folder, const MotionLevelTable& l) {
    return MakeFastestDetector(folder, l, options);
  });
}
BENCHMARK(BM_FastestDetect)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

// The YOLOX-Nano network alone on the letterboxed teddy frame, as OpenCV loads the ONNX file (arg
// 0) and rewritten (arg 1: yolox_net.h, SiLU fused and the slicing stem cut). Arg 0 also gives
// OpenCV's own time per layer type (Net::getPerfProfile) as counters [ms]. Run on one core for CPU
// time per detection: taskset -c 0 build/tests/benchmarks/stillmap_tracking_benchmark
// --benchmark_filter=YoloxNetwork
void BM_YoloxNetwork(benchmark::State& state) {  // NOLINT(readability-identifier-naming)
  const Input& in = GetInput();
  const auto models = YoloxModels(state);
  if (Skip(state, in) || !models) return;
  const std::string path = *models + "/yolox_nano/yolox_nano.onnx";
  cv::Mat canvas(320, 416, CV_8UC3, cv::Scalar(114, 114, 114));
  cv::Mat resized;
  cv::resize(in.frames[10].color, resized, cv::Size(), 0.65, 0.65, cv::INTER_LINEAR);
  resized.copyTo(canvas(cv::Rect(0, 0, resized.cols, resized.rows)));
  cv::dnn::Net original = cv::dnn::readNetFromONNX(path);
  YoloxNet rewritten(cv::dnn::readNetFromONNX(path), path, 320, 416);
  std::map<std::string, double> layer_ms;
  for (auto _ : state) {
    if (state.range(0) == 1) {
      benchmark::DoNotOptimize(rewritten.Forward(canvas).data);
      continue;
    }
    original.setInput(cv::dnn::blobFromImage(canvas, 1.0, cv::Size(), cv::Scalar(), false));
    benchmark::DoNotOptimize(original.forward().data);
    std::vector<double> ticks;
    original.getPerfProfile(ticks);
    for (size_t k = 0; k < ticks.size(); ++k) {
      layer_ms[original.getLayer(static_cast<int>(k) + 1)->type] +=
          ticks[k] * 1000.0 / cv::getTickFrequency();
    }
  }
  for (const auto& [type, ms] : layer_ms) {
    state.counters[type] = ms / static_cast<double>(state.iterations());
  }
}
BENCHMARK(BM_YoloxNetwork)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

// The tracker over the first frames (bundle adjustment inline, so its cost is included):
// the time per frame is the tracking speed.
void BM_TrackSequence(benchmark::State& state) {  // NOLINT(readability-identifier-naming)
  const Input& in = GetInput();
  if (Skip(state, in)) return;
  TrackerOptions options;
  options.local_map.background_bundle_adjustment = state.range(0) != 0;
  std::vector<double> extract, match, pose, keyframe;
  for (auto _ : state) {
    Tracker tracker(in.camera, options);
    for (size_t i = 0; i < in.frames.size(); ++i) {
      const TrackResult result =
          tracker.Track(i, in.frames[i].time, in.grays[i], in.frames[i].depth_m);
      extract.push_back(result.timings.extract_ms);
      match.push_back(result.timings.match_ms);
      pose.push_back(result.timings.pose_ms);
      keyframe.push_back(result.timings.keyframe_ms);
    }
    tracker.Finish();
  }
  auto mean = [](const std::vector<double>& v) {
    double sum = 0.0;
    for (double x : v) sum += x;
    return v.empty() ? 0.0 : sum / static_cast<double>(v.size());
  };
  state.counters["extract_ms"] = mean(extract);
  state.counters["match_ms"] = mean(match);
  state.counters["pose_ms"] = mean(pose);
  state.counters["keyframe_ms"] = mean(keyframe);
  state.counters["frames"] = static_cast<double>(in.frames.size());
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * in.frames.size()));
}
BENCHMARK(BM_TrackSequence)
    ->Arg(0)
    ->Arg(1)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(2)
    ->UseRealTime();

// The place index (the tracker's loop search, the map segments' links) holding `keyframes`
// keyframes: one keyframe's query, and the index's bytes. The keyframes are teddy's frames'
// descriptors, each used again with 8 random bits of every descriptor flipped, so that the
// buckets fill as real ORB descriptors fill them.
void BM_PlaceIndexQuery(benchmark::State& state) {  // NOLINT(readability-identifier-naming)
  const Input& in = GetInput();
  if (Skip(state, in)) return;
  std::vector<cv::Mat> frames;
  for (size_t i = 0; i < in.frames.size(); i += 2) {
    frames.push_back(
        ExtractFeatures(in.grays[i], in.frames[i].depth_m, in.camera, cv::Mat(), FeatureOptions{})
            .descriptors);
  }
  std::mt19937 generator(3);
  std::uniform_int_distribution<int> bit(0, 255);
  PlaceIndex index(PlaceIndexOptions{}, 1);
  for (int k = 0; k < state.range(0); ++k) {
    cv::Mat descriptors = frames[static_cast<size_t>(k) % frames.size()].clone();
    for (int r = 0; r < descriptors.rows; ++r) {
      for (int flip = 0; flip < 8; ++flip) {
        const int b = bit(generator);
        descriptors.at<std::uint8_t>(r, b / 8) ^= static_cast<std::uint8_t>(1U << (b % 8));
      }
    }
    index.Add(k, descriptors);
  }
  size_t query = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(
        index.Query(frames[query++ % frames.size()], 8, [](int) { return false; }));
  }
  state.counters["index_mib"] = static_cast<double>(index.MemoryBytes()) / (1024.0 * 1024.0);
  state.counters["entries"] = static_cast<double>(index.entries());
}
BENCHMARK(BM_PlaceIndexQuery)->Arg(250)->Arg(1000)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace stillmap

BENCHMARK_MAIN();
