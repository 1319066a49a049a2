#include "stillmap/tracking/dynamic_mask.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgproc.hpp>

#include "mask_growth.h"
#include "object_outline.h"
#include "stillmap/io/timing.h"

namespace stillmap {

namespace {

using mask_growth::Clip;
using object_outline::Middle;
using object_outline::Outline;

// Detections carried to a frame the detector skipped: each moved by the median flow of the
// tracked points inside it (at least 3), its mask clipped to the image.
void CarryByPairs(const std::vector<cv::Point2f>& moved_from,
                  const std::vector<cv::Point2f>& moved_to, const cv::Size& size,
                  std::vector<Detection>* carried) {
  for (Detection& detection : *carried) {
    std::vector<float> dx, dy;
    for (size_t i = 0; i < moved_from.size(); ++i) {
      if (!detection.box.contains(moved_from[i])) continue;
      dx.push_back(moved_to[i].x - moved_from[i].x);
      dy.push_back(moved_to[i].y - moved_from[i].y);
    }
    if (dx.size() < 3) continue;
    std::nth_element(dx.begin(), dx.begin() + static_cast<long>(dx.size() / 2), dx.end());
    std::nth_element(dy.begin(), dy.begin() + static_cast<long>(dy.size() / 2), dy.end());
    const cv::Point2f shift(dx[dx.size() / 2], dy[dy.size() / 2]);
    const cv::Rect before(detection.box);
    detection.box = cv::Rect2f(detection.box.tl() + shift, detection.box.size());
    if (!detection.mask.empty()) {
      // Keep the part of the mask that stays in the image.
      const cv::Rect moved(cv::Rect(detection.box).tl(), before.size());
      const cv::Rect inside = Clip(moved, size);
      if (inside.area() == 0) {
        detection.mask = cv::Mat();
        detection.box = cv::Rect2f();
        continue;
      }
      detection.mask = detection.mask(cv::Rect(inside.tl() - moved.tl(), inside.size())).clone();
      detection.box = cv::Rect2f(inside);
    } else {
      detection.box &=
          cv::Rect2f(0.0f, 0.0f, static_cast<float>(size.width), static_cast<float>(size.height));
    }
  }
}

// The median depth of the middle of `box` [m] (0: fewer than 10 readings).
float CentreDepth(const cv::Mat& depth_m, const cv::Rect2f& box) {
  const cv::Rect centre = Middle(Clip(cv::Rect(box), depth_m.size()));
  std::vector<float> depths;
  for (int v = centre.y; v < centre.y + centre.height && v < depth_m.rows; ++v) {
    for (int u = centre.x; u < centre.x + centre.width && u < depth_m.cols; ++u) {
      const float z = depth_m.at<float>(v, u);
      if (z > 0.0f) depths.push_back(z);
    }
  }
  if (depths.size() < 10) return 0.0f;
  const auto middle = depths.begin() + static_cast<long>(depths.size() / 2);
  std::nth_element(depths.begin(), middle, depths.end());
  return *middle;
}

// A detector run's detections plus the people of the last ones it missed (no detection of the
// same class overlapping them by IoU 0.3) that it had found twice in a row, each at most
// `memory_runs` runs and only while the
// middle of their box still holds something at the depth they were seen at (one who walked away
// leaves the background there).
std::vector<Detection> WithRemembered(const std::vector<Detection>& fresh,
                                      const std::vector<Detection>& last, const cv::Mat& depth_m,
                                      int memory_runs) {
  auto same = [](const Detection& a, const Detection& b) {
    const float overlap = (a.box & b.box).area();
    return a.class_id == b.class_id && overlap > 0.3f * (a.box.area() + b.box.area() - overlap);
  };
  std::vector<Detection> out = fresh;
  for (Detection& detection : out) {
    detection.centre_depth_m = CentreDepth(depth_m, detection.box);
    for (const Detection& old : last) {
      if (!same(detection, old)) continue;
      if (old.missed_runs == 0) detection.hits = old.hits + 1;
      detection.seen_moving = detection.seen_moving || old.seen_moving;
    }
  }
  for (const Detection& old : last) {
    // Only people found in two runs in a row: a single false detection on a still object would
    // otherwise be kept too.
    if (old.level != MotionLevel::kHigh || old.hits < 2 || old.missed_runs >= memory_runs) {
      continue;
    }
    const float then = old.centre_depth_m, now = CentreDepth(depth_m, old.box);
    if (!(then > 0.0f && now > 0.0f && std::abs(now - then) < 0.1f + 0.05f * then)) continue;
    const bool seen =
        std::any_of(fresh.begin(), fresh.end(),
                    [&old, &same](const Detection& other) { return same(other, old); });
    if (seen) continue;
    out.push_back(old);
    ++out.back().missed_runs;
  }
  return out;
}

// The detections' outlines into `mask` and into `claimed` (every outline); counts in `result`.
// High-level objects are masked unless geometry never saw them move and the depth check confirms
// them static (options.high_static_share); medium-level ones when geometry sees enough of them
// moving. Whether geometry saw each one move is noted in it, and carried to later runs.
void MaskDetections(std::vector<Detection>* detections, const cv::Mat& gray, const cv::Mat& depth_m,
                    const cv::Mat& geometric, const cv::Mat& consistent,
                    const DynamicMaskOptions& options, cv::Mat* mask, cv::Mat* claimed,
                    DynamicMaskResult* result) {
  const cv::Size size = gray.size();
  for (Detection& detection : *detections) {
    if (detection.level == MotionLevel::kLow || (detection.tentative && detection.hits < 2)) {
      continue;
    }
    const cv::Rect box = Clip(cv::Rect(detection.box), size);
    if (box.area() == 0) continue;
    cv::Mat outline;
    if (!detection.mask.empty() && detection.mask.size() == box.size()) {
      outline = detection.mask;
    } else if (!detection.mask.empty()) {
      continue;  // a clipped carried mask that no longer matches its box
    } else {
      outline = Outline(gray, depth_m, cv::Mat(), consistent, box, options.outline,
                        options.continuity, options.outline_whole_box);
      // An object geometry sees moving is trimmed of the readings it confirms as static (the
      // floor at a walker's feet); an object at rest keeps its whole outline.
      if (!consistent.empty() && options.outline == OutlineMode::kDepth &&
          cv::countNonZero(geometric(box) & outline) > 0) {
        outline = Outline(gray, depth_m, consistent, consistent, box, options.outline,
                          options.continuity, options.outline_whole_box);
      }
    }
    const int area = cv::countNonZero(outline);
    if (area == 0) continue;
    const int moving = cv::countNonZero(geometric(box) & outline);
    (*claimed)(box).setTo(255, outline);
    detection.seen_moving =
        detection.seen_moving || moving >= options.medium_min_moving_share * area;
    detection.left_static =
        detection.level == MotionLevel::kHigh && !detection.seen_moving && !consistent.empty() &&
        cv::countNonZero(consistent(box) & outline) >= options.high_static_share * area;
    if (detection.left_static) {
      ++result->high_static;
    } else if (detection.level == MotionLevel::kHigh) {
      ++result->high_regions;
      result->high_confirmed += moving > 0 ? 1 : 0;
      (*mask)(box).setTo(255, outline);
    } else if (moving >= options.medium_min_moving_share * area) {
      ++result->medium_moving;
      (*mask)(box).setTo(255, outline);
    } else {
      ++result->medium_static;
    }
  }
}

// DynamicMasker::WantsSecondOpinion's rule over a frame's carried detections and the moving
// pixels no detection's outline claims.
bool AskForSecondOpinion(const std::vector<Detection>& carried, const cv::Mat& geometric) {
  const cv::Size size = geometric.size();
  const float image_area = static_cast<float>(size.area());
  for (const Detection& detection : carried) {
    // A still thing taken for a person (a teddy bear), left unmasked, is no reason to ask.
    if (detection.level != MotionLevel::kHigh || detection.left_static) continue;
    const cv::Rect2f& box = detection.box;
    const bool at_border = box.x <= 2.0f || box.y <= 2.0f ||
                           box.x + box.width >= static_cast<float>(size.width) - 2.0f ||
                           box.y + box.height >= static_cast<float>(size.height) - 2.0f;
    const bool near_lens = box.area() >= image_area / 3.0f;
    if (near_lens || (at_border && detection.missed_runs > 0)) return true;
  }
  // Moving pixels outside every detection's box: a person the detector does not see, coming in
  // at the image's left or right side (where Yolo-Fastest misses people cut by the border that
  // YOLOX finds: 11 of 310 runs on bonn_crowd_a, all at the border) or anywhere.
  cv::Mat unexplained = geometric.clone();
  for (const Detection& detection : carried) {
    const cv::Rect box = cv::Rect(detection.box) + cv::Size(16, 16) - cv::Point(8, 8);
    unexplained(box & cv::Rect(cv::Point(0, 0), size)).setTo(0);
  }
  if (cv::countNonZero(unexplained) < 0.01 * image_area) return false;
  cv::Mat labels, stats, centroids;
  const int count = cv::connectedComponentsWithStats(unexplained, labels, stats, centroids, 8);
  const int side = size.width / 10;
  for (int k = 1; k < count; ++k) {
    const int area = stats.at<int>(k, cv::CC_STAT_AREA);
    const int left = stats.at<int>(k, cv::CC_STAT_LEFT);
    const int right = left + stats.at<int>(k, cv::CC_STAT_WIDTH);
    const bool at_side = left < side || right > size.width - side;
    if (static_cast<float>(area) >= (at_side ? 0.01f : 0.02f) * image_area) return true;
  }
  return false;
}

// Closes small holes (missing readings inside people), then adds the safety margin.
void CloseAndAddMargin(int margin_px, cv::Mat* mask) {
  if (cv::countNonZero(*mask) > 0) {
    cv::morphologyEx(*mask, *mask, cv::MORPH_CLOSE,
                     cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(7, 7)));
    if (margin_px > 0) {
      const int k = 2 * margin_px + 1;
      cv::dilate(*mask, *mask, cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(k, k)));
    }
  }
}

}  // namespace

void CarryDetections(const FlowStep& flow, const cv::Size& size,
                     std::vector<Detection>* detections) {
  if (flow.from.size() != flow.result.tracked.size()) return;
  std::vector<cv::Point2f> moved_from, moved_to;
  for (size_t i = 0; i < flow.from.size(); ++i) {
    if (flow.result.tracked[i] == 0) continue;
    moved_from.push_back(flow.from[i]);
    moved_to.push_back(flow.result.current[i]);
  }
  CarryByPairs(moved_from, moved_to, size, detections);
}

cv::Mat NearestStaticDepth(const MaskReference& reference) {
  cv::Mat nearest = reference.depth_m.clone();
  if (!reference.mask.empty()) nearest.setTo(0.0f, reference.mask);
  cv::erode(nearest, nearest, cv::getStructuringElement(cv::MORPH_RECT, cv::Size(5, 5)));
  return nearest;  // 0 (no reading, or moving) wins: no evidence
}

// ---- Fusion ------------------------------------------------------------------------------------

DynamicMasker::DynamicMasker(const Camera& camera, const DynamicMaskOptions& options)
    : camera_(camera),
      options_(options),
      geometry_(camera, options),
      flow_tracker_(ResolvedFlowPoints(options.flow_points, false), options.flow) {
  options.Validate();
}

std::vector<FoundMoving> DynamicMasker::AddReference(MaskReference reference) {
  // The older references are checked against the new one: people they saw who have moved on
  // since are found now, and left out of the comparisons to come (an unmasked person in a
  // reference otherwise vouches for the person being static where they stood).
  reference.nearest_depth_m = NearestStaticDepth(reference);  // once, for every check below
  std::vector<FoundMoving> found_moving;
  if (options_.depth_check) {
    const std::vector<const MaskReference*> newest = {&reference};
    for (MaskReference& older : references_) {
      if (reference.time - older.time < options_.reference_spacing_s) continue;
      const cv::Mat found = geometry_.Compute(older.depth_m, older.world_from_camera, newest);
      if (cv::countNonZero(found) == 0) continue;
      older.mask = older.mask.empty() ? found : (older.mask | found);
      older.nearest_depth_m = NearestStaticDepth(older);
      found_moving.push_back({older.keyframe_id, found});
    }
  }
  references_.push_front(std::move(reference));
  const double horizon = options_.ReferenceHorizonS();
  while (references_.size() > 1 && references_.front().time - references_.back().time > horizon) {
    references_.pop_back();
  }
  return found_moving;
}

void DynamicMasker::Repose(const std::map<int, Eigen::Isometry3d>& world_from_keyframe) {
  for (MaskReference& reference : references_) {
    const auto it = world_from_keyframe.find(reference.keyframe_id);
    if (it != world_from_keyframe.end()) reference.world_from_camera = it->second;
  }
}

std::vector<const MaskReference*> DynamicMasker::References() const {
  std::vector<const MaskReference*> newest_first;
  for (const MaskReference& reference : references_) newest_first.push_back(&reference);
  return SpreadInTime(newest_first, options_.reference_spacing_s,
                      static_cast<size_t>(options_.reference_keyframes));
}

std::vector<const MaskReference*> SpreadInTime(
    const std::vector<const MaskReference*>& newest_first, double spacing_s, size_t count) {
  // The newest, then each next one at least spacing_s older than the last chosen.
  std::vector<const MaskReference*> chosen;
  double last_time = std::numeric_limits<double>::infinity();
  for (const MaskReference* reference : newest_first) {
    if (chosen.size() >= count) break;
    if (!chosen.empty() && last_time - reference->time < spacing_s) continue;
    chosen.push_back(reference);
    last_time = reference->time;
  }
  return chosen;
}

std::vector<cv::Point> DynamicMasker::FlowSeeds(const FlowStep& flow, const cv::Mat& depth_m,
                                                std::vector<cv::Point2f>* moved_from,
                                                std::vector<cv::Point2f>* moved_to) const {
  std::vector<cv::Point> seeds;
  const FlowCheckResult& result = flow.result;
  if (flow.from.size() != result.tracked.size()) return seeds;
  for (size_t i = 0; i < flow.from.size(); ++i) {
    if (result.tracked[i] == 0) continue;
    moved_from->push_back(flow.from[i]);
    moved_to->push_back(result.current[i]);
    if (!options_.flow_check || !result.fundamental_found || result.dynamic[i] == 0) continue;
    const float pu = std::floor(result.current[i].x + 0.5f);
    const float pv = std::floor(result.current[i].y + 0.5f);
    if (!(pu >= 0.0f && pv >= 0.0f && pu < static_cast<float>(depth_m.cols) &&
          pv < static_cast<float>(depth_m.rows))) {
      continue;
    }
    const cv::Point pixel(static_cast<int>(pu), static_cast<int>(pv));
    if (depth_m.at<float>(pixel) > 0.0f) seeds.push_back(pixel);
  }
  return seeds;
}

DynamicMaskResult DynamicMasker::Compute(const cv::Mat& gray, const cv::Mat& depth_m,
                                         const std::optional<Eigen::Isometry3d>& world_from_camera,
                                         const std::vector<Detection>* detections,
                                         const FlowStep* flow) {
  const auto start = std::chrono::steady_clock::now();
  CV_Assert(gray.type() == CV_8UC1 && depth_m.type() == CV_32FC1 && gray.size() == depth_m.size());
  DynamicMaskResult result;
  const cv::Size size = gray.size();

  // Flow: seeds for the geometry, and the motion that carries detections between detector runs.
  std::vector<cv::Point2f> moved_from, moved_to;
  std::vector<cv::Point> flow_seeds;
  FlowStep own_flow;
  if (options_.TracksFlow() && flow == nullptr) {
    own_flow = flow_tracker_.Next(gray);
    flow = &own_flow;
  }
  if (flow != nullptr) flow_seeds = FlowSeeds(*flow, depth_m, &moved_from, &moved_to);
  result.flow_seeds = static_cast<int>(flow_seeds.size());

  cv::Mat geometric(size, CV_8UC1, cv::Scalar(0));
  cv::Mat consistent;  // readings a reference confirms as static
  const bool geometry = options_.depth_check || options_.flow_check;
  if (geometry && world_from_camera) {
    std::vector<const MaskReference*> references;
    if (options_.depth_check) references = References();
    geometric = geometry_.Compute(depth_m, *world_from_camera, references, flow_seeds,
                                  &result.depth_seeds, &consistent);
  } else if (geometry && !flow_seeds.empty()) {
    // No pose: flow seeds alone, grown over depth-continuous pixels.
    geometric = geometry_.Compute(depth_m, Eigen::Isometry3d::Identity(), {}, flow_seeds, nullptr);
  }

  // Detections: this frame's, or the last ones moved by the median flow of the points in them.
  if (detections != nullptr) {
    carried_ = WithRemembered(*detections, carried_, depth_m, options_.detection_memory_runs);
    result.detections_fresh = true;
  } else {
    CarryByPairs(moved_from, moved_to, size, &carried_);
  }

  cv::Mat mask = geometric.clone();
  cv::Mat claimed(size, CV_8UC1, cv::Scalar(0));  // pixels of any detection's outline
  if (options_.semantics) {
    MaskDetections(&carried_, gray, depth_m, geometric, consistent, options_, &mask, &claimed,
                   &result);
  }
  result.geometric_pixels = cv::countNonZero(geometric);
  if (result.geometric_pixels > 0) {  // the regions' labelling only where there are regions
    const object_outline::UnclaimedRegions unclaimed = object_outline::OutlineUnclaimedRegions(
        gray, depth_m, geometric, claimed, consistent, options_, &mask);
    result.geometric_only_regions = unclaimed.count;
    result.geometric_outlined = unclaimed.outlined;
  }
  // Looked for only where a second opinion can be asked (a share above 0): the check walks the
  // whole image.
  wants_second_opinion_ = options_.semantics && options_.second_opinion_share > 0.0 &&
                          AskForSecondOpinion(carried_, geometric);
  // Close small holes (missing readings inside people), then the safety margin.
  CloseAndAddMargin(options_.margin_px, &mask);
  result.mask = mask;
  result.share = static_cast<double>(cv::countNonZero(mask)) / static_cast<double>(mask.total());

  result.ms = MillisecondsSince(start);
  return result;
}

}  // namespace stillmap
