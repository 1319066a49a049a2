#include "stillmap/tracking/flow_check.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>

#include "stillmap/io/timing.h"

namespace stillmap {

std::vector<int> Dbscan(const std::vector<cv::Point2f>& points, double epsilon, int min_points) {
  const size_t n = points.size();
  const float epsilon2 = static_cast<float>(epsilon * epsilon);
  // A few hundred to a few thousand points per frame: the quadratic neighbour search costs well
  // under a millisecond at 1000 points, less than building an index.
  auto neighbours = [&](size_t i) {
    std::vector<size_t> out;
    for (size_t j = 0; j < n; ++j) {
      const cv::Point2f d = points[i] - points[j];
      if (d.x * d.x + d.y * d.y <= epsilon2) out.push_back(j);
    }
    return out;
  };
  constexpr int kUnvisited = -2, kNoise = -1;
  std::vector<int> label(n, kUnvisited);
  int cluster = 0;
  for (size_t i = 0; i < n; ++i) {
    if (label[i] != kUnvisited) continue;
    std::vector<size_t> seeds = neighbours(i);
    if (static_cast<int>(seeds.size()) < min_points) {
      label[i] = kNoise;
      continue;
    }
    label[i] = cluster;
    for (size_t k = 0; k < seeds.size(); ++k) {
      const size_t j = seeds[k];
      if (label[j] == kNoise) label[j] = cluster;  // a border point
      if (label[j] != kUnvisited) continue;
      label[j] = cluster;
      const std::vector<size_t> more = neighbours(j);
      if (static_cast<int>(more.size()) >= min_points) {
        seeds.insert(seeds.end(), more.begin(), more.end());  // a core point: grow
      }
    }
    ++cluster;
  }
  return label;
}

namespace {

cv::Size KltWindow(const FlowCheckOptions& options) {
  const int edge = ResolvedKltWindow(options.klt_window, false);
  return {edge, edge};
}

}  // namespace

FlowPyramid BuildFlowPyramid(const cv::Mat& gray, const FlowCheckOptions& options) {
  FlowPyramid pyramid;
  pyramid.size = gray.size();
  // A copy of the image, not a view of it: callers reuse their image buffers.
  cv::buildOpticalFlowPyramid(gray, pyramid.levels, KltWindow(options), options.klt_levels, true,
                              cv::BORDER_REFLECT_101, cv::BORDER_CONSTANT, false);
  return pyramid;
}

std::vector<cv::Point2f> FlowCorners(const cv::Mat& gray, int count, double min_distance_px) {
  cv::Mat half;
  cv::pyrDown(gray, half);
  std::vector<cv::Point2f> corners;
  cv::goodFeaturesToTrack(half, corners, count, 0.01, min_distance_px / 2.0);
  // Pixel centres: half-resolution pixel (x, y) covers full-resolution 2x .. 2x + 1.
  for (cv::Point2f& corner : corners) corner = corner * 2.0f + cv::Point2f(0.5f, 0.5f);
  return corners;
}

FlowStep FlowTracker::Next(const cv::Mat& gray) {
  const auto start = std::chrono::steady_clock::now();
  FlowStep step;
  FlowPyramid pyramid = BuildFlowPyramid(gray, options_);
  if (!previous_pyramid_.empty() && previous_pyramid_.size == pyramid.size &&
      previous_corners_.size() >= 8) {
    step.result = CheckFlow(previous_pyramid_, pyramid, previous_corners_, options_);
    step.from = std::move(previous_corners_);
  }
  previous_pyramid_ = std::move(pyramid);
  previous_corners_ = FlowCorners(gray, corners_, 8.0);
  step.ms = MillisecondsSince(start);
  return step;
}

FlowCheckResult CheckFlow(const cv::Mat& previous_gray, const cv::Mat& gray,
                          const std::vector<cv::Point2f>& previous_points,
                          const FlowCheckOptions& options) {
  return CheckFlow(BuildFlowPyramid(previous_gray, options), BuildFlowPyramid(gray, options),
                   previous_points, options);
}

FlowCheckResult CheckFlow(const FlowPyramid& previous, const FlowPyramid& current,
                          const std::vector<cv::Point2f>& previous_points,
                          const FlowCheckOptions& options) {
  CV_Assert(previous.size == current.size);
  const size_t n = previous_points.size();
  FlowCheckResult result;
  result.current.assign(n, cv::Point2f());
  result.tracked.assign(n, 0);
  result.dynamic.assign(n, 0);
  result.flow_length_px.assign(n, 0.0f);
  result.epipolar_distance_px.assign(n, 0.0f);
  if (n < 8) return result;

  // 1-2: KLT flow, with a forward-backward check to drop bad tracks.
  const cv::Size window = KltWindow(options);
  std::vector<cv::Point2f> forward, backward;
  std::vector<std::uint8_t> status_forward, status_backward;
  std::vector<float> errors;
  cv::calcOpticalFlowPyrLK(previous.levels, current.levels, previous_points, forward,
                           status_forward, errors, window, options.klt_levels);
  cv::calcOpticalFlowPyrLK(current.levels, previous.levels, forward, backward, status_backward,
                           errors, window, options.klt_levels);
  std::vector<size_t> kept;
  std::vector<cv::Point2f> from, to;
  const float limit2 =
      static_cast<float>(options.max_forward_backward_px * options.max_forward_backward_px);
  for (size_t i = 0; i < n; ++i) {
    result.current[i] = forward[i];
    const cv::Point2f round_trip = backward[i] - previous_points[i];
    const bool inside = forward[i].x >= 0 && forward[i].y >= 0 &&
                        forward[i].x < static_cast<float>(current.size.width) &&
                        forward[i].y < static_cast<float>(current.size.height);
    if (status_forward[i] == 0 || status_backward[i] == 0 || !inside ||
        round_trip.x * round_trip.x + round_trip.y * round_trip.y > limit2) {
      continue;
    }
    result.tracked[i] = 1;
    kept.push_back(i);
    from.push_back(previous_points[i]);
    to.push_back(forward[i]);
  }
  if (kept.size() < 8) return result;

  // 3: the fundamental matrix by RANSAC.
  const cv::Mat fundamental =
      cv::findFundamentalMat(from, to, cv::FM_RANSAC, options.ransac_threshold_px, 0.99);
  if (fundamental.rows != 3 || fundamental.cols != 3) return result;
  result.fundamental_found = true;
  const cv::Matx33d f(fundamental);

  // 4-7: (d_v, d_l) per track; eq. (1) and (3) of paper 004.
  std::vector<cv::Point2f> features;
  features.reserve(kept.size());
  for (size_t k = 0; k < kept.size(); ++k) {
    const cv::Vec3d line = f * cv::Vec3d(from[k].x, from[k].y, 1.0);
    const double norm = std::hypot(line[0], line[1]);
    const double distance =
        norm > 0.0 ? std::abs(line[0] * to[k].x + line[1] * to[k].y + line[2]) / norm : 0.0;
    const cv::Point2f flow = to[k] - from[k];
    const float length = std::hypot(flow.x, flow.y);
    result.flow_length_px[kept[k]] = length;
    result.epipolar_distance_px[kept[k]] = static_cast<float>(distance);
    features.emplace_back(length, static_cast<float>(distance));
  }

  // 8-11: DBSCAN; everything outside the largest cluster is dynamic.
  const std::vector<int> labels =
      Dbscan(features, options.dbscan_epsilon_px, options.dbscan_min_points);
  std::vector<size_t> sizes;
  for (int label : labels) {
    if (label < 0) continue;
    if (static_cast<size_t>(label) >= sizes.size()) sizes.resize(static_cast<size_t>(label) + 1);
    ++sizes[static_cast<size_t>(label)];
  }
  const int largest =
      sizes.empty()
          ? -1
          : static_cast<int>(std::max_element(sizes.begin(), sizes.end()) - sizes.begin());
  for (size_t k = 0; k < kept.size(); ++k) {
    result.dynamic[kept[k]] = labels[k] != largest && result.epipolar_distance_px[kept[k]] >=
                                                          options.min_epipolar_distance_px
                                  ? 1
                                  : 0;
  }
  return result;
}

}  // namespace stillmap
