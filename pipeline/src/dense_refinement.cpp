#include "dense_refinement.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <future>
#include <list>
#include <memory>
#include <optional>
#include <utility>

#include "stillmap/tracking/pose_graph.h"

namespace stillmap {
namespace {

struct Pair {
  size_t a = 0, b = 0;  // node indices, a before b
  bool revisit = false;
};

// The last keyframes' images decoded, least recently used dropped first.
class ImageCache {
 public:
  ImageCache(const KeyframeImages& images, size_t capacity)
      : images_(images), capacity_(capacity) {}

  std::shared_ptr<const RgbdImages> Get(size_t index) {
    for (auto it = entries_.begin(); it != entries_.end(); ++it) {
      if (it->first != index) continue;
      entries_.splice(entries_.begin(), entries_, it);
      return it->second;
    }
    auto images = std::make_shared<RgbdImages>();
    images_(index, &images->gray, &images->depth_m);
    cv::compare(images->depth_m, 0.0, images->ignore_mask, cv::CMP_LE);
    entries_.emplace_front(index, images);
    if (entries_.size() > capacity_) entries_.pop_back();
    return images;
  }

 private:
  const KeyframeImages& images_;
  size_t capacity_;
  std::list<std::pair<size_t, std::shared_ptr<const RgbdImages>>> entries_;
};

double AxisAngleDeg(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  const double cosine = a.linear().col(2).dot(b.linear().col(2));
  return std::acos(std::clamp(cosine, -1.0, 1.0)) * 180.0 / M_PI;
}

// The keyframes of another time nearest to node b, whose views overlap its view.
std::vector<size_t> RevisitPartners(const std::vector<RefinedKeyframe>& nodes, size_t b,
                                    const DenseRefinementOptions& options) {
  std::vector<std::pair<double, size_t>> near;
  for (size_t a = 0; a < b; ++a) {
    if (nodes[b].time - nodes[a].time < options.revisit_min_gap_s) break;
    const double distance =
        (nodes[a].world_from_camera.translation() - nodes[b].world_from_camera.translation())
            .norm();
    if (distance > options.revisit_max_distance_m) continue;
    if (AxisAngleDeg(nodes[a].world_from_camera, nodes[b].world_from_camera) >
        options.revisit_max_angle_deg)
      continue;
    near.emplace_back(distance, a);
  }
  std::sort(near.begin(), near.end());
  std::vector<size_t> partners;
  for (size_t k = 0;
       k < near.size() && partners.size() < static_cast<size_t>(options.revisit_pairs); ++k) {
    partners.push_back(near[k].second);
  }
  return partners;
}

std::vector<Pair> Pairs(const std::vector<RefinedKeyframe>& nodes,
                        const DenseRefinementOptions& options) {
  std::vector<Pair> pairs;
  for (size_t b = 0; b < nodes.size(); ++b) {
    for (size_t a = b > static_cast<size_t>(options.next_keyframes) ? b - options.next_keyframes
                                                                    : 0;
         a < b; ++a) {
      if (nodes[b].time - nodes[a].time <= options.max_next_gap_s) pairs.push_back({a, b, false});
    }
    for (size_t a : RevisitPartners(nodes, b, options)) pairs.push_back({a, b, true});
  }
  return pairs;
}

// An alignment of pair b to a: the measured pose of b in a's frame.
struct Measured {
  Pair pair;
  Eigen::Isometry3d initial;  // as the poses have it
  Eigen::Isometry3d aligned;
};

// How far `aligned` moves a pair from `initial`: [m] and [deg].
std::pair<double, double> Change(const Eigen::Isometry3d& initial,
                                 const Eigen::Isometry3d& aligned) {
  const Eigen::Isometry3d change = initial.inverse() * aligned;
  return {change.translation().norm(), RotationAngleDeg(change)};
}

bool Within(const std::pair<double, double>& change, double max_m, double max_deg) {
  return change.first <= max_m && change.second <= max_deg;
}

// The alignments' relative poses between keyframes to the next ones, by pair, both ways.
class NextAlignments {
 public:
  explicit NextAlignments(const std::vector<Measured>& measured) {
    for (const Measured& m : measured) {
      if (m.pair.revisit) continue;
      poses_[{m.pair.a, m.pair.b}] = m.aligned;
      poses_[{m.pair.b, m.pair.a}] = m.aligned.inverse();
      neighbours_[m.pair.a].push_back(m.pair.b);
      neighbours_[m.pair.b].push_back(m.pair.a);
    }
  }
  // Whether the alignment of (a, b) is in a triangle of alignments (a, c, b), and whether one
  // such triangle closes within max_m and max_deg.
  std::pair<bool, bool> Triangle(size_t a, size_t b, double max_m, double max_deg) const {
    const Eigen::Isometry3d& direct = poses_.at({a, b});
    bool any = false;
    for (size_t c : neighbours_.at(a)) {
      if (c == b) continue;
      const auto to_b = poses_.find({c, b});
      if (to_b == poses_.end()) continue;
      any = true;
      if (Within(Change(direct, poses_.at({a, c}) * to_b->second), max_m, max_deg)) {
        return {true, true};
      }
    }
    return {any, false};
  }

 private:
  std::map<std::pair<size_t, size_t>, Eigen::Isometry3d> poses_;
  std::map<size_t, std::vector<size_t>> neighbours_;
};

// Whether an alignment is taken. To a keyframe of another time: within revisit_max_change_*
// of the poses. To the next ones: where it forms a triangle with other such alignments, when
// one closes within cycle_max_* and it is within revisit_max_change_* (so that it can correct a
// feature pose gone wrong); where it forms none, within max_change_*.
bool Taken(const Measured& m, const NextAlignments& next, const DenseRefinementOptions& options) {
  const std::pair<double, double> change = Change(m.initial, m.aligned);
  const bool near = Within(change, options.revisit_max_change_m, options.revisit_max_change_deg);
  if (m.pair.revisit) return near;
  const auto [in_triangle, closes] =
      next.Triangle(m.pair.a, m.pair.b, options.cycle_max_m, options.cycle_max_deg);
  if (in_triangle) return closes && near;
  return Within(change, options.max_change_m, options.max_change_deg);
}

// The cameras and options of an alignment: the coarse one first (when coarse_cell_px is set),
// then the fine one.
struct AlignmentLevels {
  AlignmentLevels(const Camera& camera, const DenseRefinementOptions& options)
      : fine_cells(camera, options.cell_px) {
    fine.cell_px = options.cell_px;
    coarse.cell_px = options.coarse_cell_px;
    if (options.coarse_cell_px > 0) coarse_cells.emplace(camera, options.coarse_cell_px);
  }
  CellCamera fine_cells;
  std::optional<CellCamera> coarse_cells;  // none: no coarse alignment
  RgbdOdometryOptions fine, coarse;
};

// Pair b aligned to a from `initial`: on the coarse cells first, and on the fine ones from there
// where the coarse alignment was taken, else from `initial`.
RgbdAlignment AlignPair(const AlignmentLevels& levels, const RgbdImages& reference,
                        const RgbdImages& current, const Eigen::Isometry3d& initial) {
  Eigen::Isometry3d start = initial;
  if (levels.coarse_cells) {
    const RgbdAlignment coarse =
        AlignRgbd(*levels.coarse_cells, reference, current, initial, levels.coarse);
    if (coarse.ok()) start = coarse.reference_from_current;
  }
  return AlignRgbd(levels.fine_cells, reference, current, start, levels.fine);
}

// The alignments of `pairs[first, last)` that are taken as alignments (RgbdAlignment::ok).
std::vector<std::optional<Measured>> AlignRange(const AlignmentLevels& levels,
                                                const KeyframeImages& images,
                                                const std::vector<RefinedKeyframe>& nodes,
                                                const std::vector<Pair>& pairs, size_t first,
                                                size_t last) {
  ImageCache cache(images, 24);
  std::vector<std::optional<Measured>> measured(last - first);
  for (size_t i = first; i < last; ++i) {
    const Pair& pair = pairs[i];
    const Eigen::Isometry3d initial =
        nodes[pair.a].world_from_camera.inverse() * nodes[pair.b].world_from_camera;
    const std::shared_ptr<const RgbdImages> reference = cache.Get(pair.a);
    const std::shared_ptr<const RgbdImages> current = cache.Get(pair.b);
    const RgbdAlignment aligned = AlignPair(levels, *reference, *current, initial);
    if (aligned.ok()) measured[i - first] = Measured{pair, initial, aligned.reference_from_current};
  }
  return measured;
}

// Every pair aligned, in the pairs' order whether or not on two threads (`parallel`).
std::vector<Measured> AlignPairs(const Camera& camera, const KeyframeImages& images,
                                 const std::vector<RefinedKeyframe>& nodes,
                                 const std::vector<Pair>& pairs,
                                 const DenseRefinementOptions& options, bool parallel) {
  const AlignmentLevels levels(camera, options);
  const size_t half = parallel ? pairs.size() / 2 : pairs.size();
  std::future<std::vector<std::optional<Measured>>> second =
      std::async(parallel ? std::launch::async : std::launch::deferred,
                 [&] { return AlignRange(levels, images, nodes, pairs, half, pairs.size()); });
  std::vector<std::optional<Measured>> all = AlignRange(levels, images, nodes, pairs, 0, half);
  for (std::optional<Measured>& m : second.get()) all.push_back(std::move(m));
  std::vector<Measured> measured;
  for (std::optional<Measured>& m : all) {
    if (m) measured.push_back(*m);
  }
  return measured;
}

// The weight that makes an edge of the graph's noise `graph_sigma` as sure as `sigma`.
double WeightFor(double graph_sigma, double sigma) { return std::pow(graph_sigma / sigma, 2); }

// The path between consecutive keyframes [m]: the camera's travel plus its turn at 0.5 m a
// radian, so that a turn in place counts too.
std::vector<double> PathTo(const std::vector<RefinedKeyframe>& nodes) {
  std::vector<double> path(nodes.size(), 0.0);
  for (size_t k = 1; k < nodes.size(); ++k) {
    const Eigen::Isometry3d& a = nodes[k - 1].world_from_camera;
    const Eigen::Isometry3d& b = nodes[k].world_from_camera;
    path[k] = path[k - 1] + (b.translation() - a.translation()).norm() +
              0.5 * RotationAngleDeg(a.inverse() * b) * M_PI / 180.0;
  }
  return path;
}

// Per node, how many of the steps into nodes 1..k began tracking anew: the stretch between
// nodes j and k holds one when the counts differ.
std::vector<int> AnewSteps(const std::vector<RefinedKeyframe>& nodes) {
  std::vector<int> count(nodes.size(), 0);
  for (size_t k = 1; k < nodes.size(); ++k) count[k] = count[k - 1] + (nodes[k].anew ? 1 : 0);
  return count;
}

// The edge from node k - 1 to k as the poses have it: the graph's own noise, its translation
// `extra_m` less sure where tracking began anew in between (its rotation as sure).
PoseGraphEdge StepEdge(const std::vector<RefinedKeyframe>& nodes, size_t k, double extra_m,
                       const PoseGraphOptions& graph_options) {
  const int to = static_cast<int>(k);
  PoseGraphEdge edge =
      EdgeBetween(to - 1, to, nodes[k - 1].world_from_camera, nodes[k].world_from_camera);
  if (extra_m > 0.0) {
    edge.weight =
        WeightFor(graph_options.translation_sigma_m, graph_options.translation_sigma_m + extra_m);
    edge.rotation_share = 1.0 / edge.weight;
  }
  return edge;
}

// The poses' shape as a pose graph: consecutive keyframes as the poses have them (the graph's
// own noise), each keyframe to the first (prior_sigma_m), and to the keyframes 2, 4, 8 ... after
// it (span_sigma_m plus span_drift_share of the path between); each edge over a step where
// tracking began anew anew_sigma_m less sure in translation.
PoseGraphProblem ShapeGraph(const std::vector<RefinedKeyframe>& nodes,
                            const DenseRefinementOptions& options,
                            const PoseGraphOptions& graph_options) {
  const bool held = options.prior_sigma_m > 0.0;
  const double prior_weight =
      held ? WeightFor(graph_options.translation_sigma_m, options.prior_sigma_m) : 0.0;
  const std::vector<double> path = PathTo(nodes);
  const std::vector<int> anew = AnewSteps(nodes);
  const auto extra_m = [&](size_t from, size_t to) {
    return anew[to] > anew[from] ? options.anew_sigma_m : 0.0;
  };
  PoseGraphProblem problem;
  for (size_t k = 0; k < nodes.size(); ++k) {
    const Eigen::Isometry3d& pose = nodes[k].world_from_camera;
    problem.world_from_node.push_back(pose);
    problem.fixed.push_back(k == 0);
    const int to = static_cast<int>(k);
    if (k > 0) problem.edges.push_back(StepEdge(nodes, k, extra_m(k - 1, k), graph_options));
    if (k > 1 && held) {  // an edge to the fixed node (node 1's is its shape edge already)
      problem.edges.push_back(EdgeBetween(0, to, nodes[0].world_from_camera, pose, prior_weight));
    }
    if (options.span_drift_share <= 0.0) continue;
    for (size_t span = 2; span <= static_cast<size_t>(options.max_span_keyframes) && span <= k;
         span *= 2) {
      const double path_m = path[k] - path[k - span];
      const double sigma_m =
          options.span_sigma_m + options.span_drift_share * path_m + extra_m(k - span, k);
      const double sigma_rad =
          (options.span_rotation_sigma_deg + options.span_rotation_drift_deg_per_m * path_m) *
          M_PI / 180.0;
      PoseGraphEdge edge =
          EdgeBetween(static_cast<int>(k - span), to, nodes[k - span].world_from_camera, pose,
                      WeightFor(graph_options.translation_sigma_m, sigma_m));
      edge.rotation_share = WeightFor(graph_options.rotation_sigma_rad, sigma_rad) / edge.weight;
      problem.edges.push_back(edge);
    }
  }
  return problem;
}

}  // namespace

DenseRefinementFigures RefineKeyframePoses(const Camera& camera, const KeyframeImages& images,
                                           const DenseRefinementOptions& options,
                                           std::vector<RefinedKeyframe>* keyframes, bool parallel) {
  const auto start = std::chrono::steady_clock::now();
  DenseRefinementFigures figures;
  const std::vector<RefinedKeyframe>& nodes = *keyframes;
  figures.keyframes = nodes.size();
  if (nodes.size() < 2) return figures;
  const PoseGraphOptions graph_options;
  const double weight = WeightFor(graph_options.translation_sigma_m, options.alignment_sigma_m);
  PoseGraphProblem problem = ShapeGraph(nodes, options, graph_options);
  const std::vector<Pair> pairs = Pairs(nodes, options);
  for (const Pair& pair : pairs) (pair.revisit ? figures.revisit_pairs : figures.next_pairs) += 1;
  const std::vector<Measured> measured =
      AlignPairs(camera, images, nodes, pairs, options, parallel);
  const NextAlignments next(measured);
  for (const Measured& m : measured) {
    if (!Taken(m, next, options)) continue;
    (m.pair.revisit ? figures.revisit_taken : figures.next_taken) += 1;
    problem.edges.push_back(
        {static_cast<int>(m.pair.a), static_cast<int>(m.pair.b), m.aligned, weight});
  }
  if (figures.next_taken + figures.revisit_taken > 0) {
    const PoseGraphResult solved = SolvePoseGraph(problem, graph_options);
    for (size_t k = 0; k < nodes.size(); ++k) {
      const Eigen::Isometry3d& refined = solved.world_from_node[k];
      figures.largest_move_m =
          std::max(figures.largest_move_m,
                   (refined.translation() - nodes[k].world_from_camera.translation()).norm());
      (*keyframes)[k].world_from_camera = refined;
    }
  }
  figures.ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  return figures;
}

namespace {

using TimedCorrection = std::pair<double, Eigen::Isometry3d>;

// `correction` taken by `share` (0: none, 1: all of it).
Eigen::Isometry3d Part(const Eigen::Isometry3d& correction, double share) {
  return InterpolatePose(Eigen::Isometry3d::Identity(), correction, std::clamp(share, 0.0, 1.0));
}

using Corrections = std::vector<TimedCorrection>::const_iterator;

// Orders corrections by their keyframe's time against a time (std::lower_bound).
bool EarlierThan(const TimedCorrection& correction, double time) { return correction.first < time; }

// The keyframes' corrections in [begin, end) interpolated between the two on either side of `t`
// in time; `next` is the first keyframe after `t`. Where those two are more than `max_gap_s`
// apart, or on the far side of the first or last keyframe, the frame takes the nearer keyframe's
// correction fading to none over `max_gap_s`: such frames were tracked against the map's older
// keyframes (a revisit), not against these two.
Eigen::Isometry3d InterpolatedCorrection(Corrections begin, Corrections end, Corrections next,
                                         double t, double max_gap_s) {
  if (next == begin) return Part(next->second, 1.0 - (next->first - t) / max_gap_s);
  const auto previous = std::prev(next);
  if (next == end) return Part(previous->second, 1.0 - (t - previous->first) / max_gap_s);
  if (next->first - previous->first > max_gap_s) {
    const double after = t - previous->first, before = next->first - t;
    return after <= before ? Part(previous->second, 1.0 - after / max_gap_s)
                           : Part(next->second, 1.0 - before / max_gap_s);
  }
  const double share = (t - previous->first) / (next->first - previous->first);
  return InterpolatePose(previous->second, next->second, share);
}

// The corrections of the keyframes in [begin, end) within three smoothing_s of `t`, weighted by
// a Gaussian of that width (translation and quaternion averaged); nothing when none is that near.
std::optional<Eigen::Isometry3d> SmoothedCorrection(Corrections begin, Corrections end, double t,
                                                    double smoothing_s) {
  const auto first = std::lower_bound(begin, end, t - 3.0 * smoothing_s, EarlierThan);
  double total = 0.0;
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();
  Eigen::Vector4d rotation = Eigen::Vector4d::Zero();
  std::optional<Eigen::Quaterniond> reference;
  for (auto it = first; it != end && it->first <= t + 3.0 * smoothing_s; ++it) {
    const double z = (it->first - t) / smoothing_s;
    const double weight = std::exp(-0.5 * z * z);
    Eigen::Quaterniond q(it->second.linear());
    if (!reference) reference = q;
    if (q.dot(*reference) < 0.0) q.coeffs() = -q.coeffs();  // one hemisphere
    translation += weight * it->second.translation();
    rotation += weight * q.coeffs();
    total += weight;
  }
  if (total <= 0.0) return std::nullopt;
  Eigen::Isometry3d smoothed = Eigen::Isometry3d::Identity();
  smoothed.linear() = Eigen::Quaterniond(rotation / total).normalized().toRotationMatrix();
  smoothed.translation() = translation / total;
  return smoothed;
}

// The keyframes of the run of frames `t` lies in (a run begins at each of `run_start_times`, where
// a new map segment began): keyframes of another run were tracked on another chain, and their
// corrections are not this frame's. All of them when its run holds none.
std::pair<Corrections, Corrections> RunKeyframes(const std::vector<TimedCorrection>& corrections,
                                                 const std::vector<double>& run_start_times,
                                                 double t) {
  const auto next_start = std::upper_bound(run_start_times.begin(), run_start_times.end(), t);
  const Corrections begin = next_start == run_start_times.begin()
                                ? corrections.begin()
                                : std::lower_bound(corrections.begin(), corrections.end(),
                                                   *std::prev(next_start), EarlierThan);
  const Corrections end =
      next_start == run_start_times.end()
          ? corrections.end()
          : std::lower_bound(corrections.begin(), corrections.end(), *next_start, EarlierThan);
  if (begin == end) return {corrections.begin(), corrections.end()};
  return {begin, end};
}

}  // namespace

void CarryCorrections(const std::map<int, Eigen::Isometry3d>& before,
                      const std::map<int, Eigen::Isometry3d>& after,
                      const std::map<int, double>& times, const std::vector<bool>& in_map,
                      const std::vector<double>& run_start_times, double smoothing_s,
                      double max_gap_s, Trajectory* trajectory) {
  std::vector<TimedCorrection> corrections;
  corrections.reserve(before.size());
  for (const auto& [id, pose] : before) {
    corrections.emplace_back(times.at(id), after.at(id) * pose.inverse());
  }
  if (corrections.empty()) return;
  std::sort(corrections.begin(), corrections.end(),
            [](const auto& x, const auto& y) { return x.first < y.first; });
  std::vector<StampedPose> poses = trajectory->poses();
  for (size_t i = 0; i < poses.size(); ++i) {
    if (!in_map[i]) continue;
    const double t = poses[i].time;
    const auto [begin, end] = RunKeyframes(corrections, run_start_times, t);
    const auto at = std::lower_bound(begin, end, t, EarlierThan);
    const bool keyframe = at != end && at->first == t;
    // Averaged only between keyframes at most max_gap_s apart: elsewhere the frame was tracked
    // against older keyframes (a revisit), and takes the fade.
    const bool between_near_keyframes =
        at != begin && at != end && at->first - std::prev(at)->first <= max_gap_s;
    std::optional<Eigen::Isometry3d> correction;
    if (keyframe) {
      correction = at->second;
    } else if (smoothing_s > 0.0 && between_near_keyframes) {
      correction = SmoothedCorrection(begin, end, t, smoothing_s);
    }
    if (!correction) correction = InterpolatedCorrection(begin, end, at, t, max_gap_s);
    poses[i].world_from_camera = *correction * poses[i].world_from_camera;
  }
  *trajectory = Trajectory(std::move(poses));
}

}  // namespace stillmap
