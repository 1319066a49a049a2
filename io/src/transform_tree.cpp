#include "stillmap/io/transform_tree.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "stillmap/io/error.h"
#include "stillmap/io/trajectory.h"

namespace stillmap {

std::string TransformTree::FrameName(const std::string& name) {
  const size_t first = name.find_first_not_of('/');
  return first == std::string::npos ? std::string() : name.substr(first);
}

bool TransformTree::Add(const TransformSample& sample, bool is_static, std::string* why) {
  const std::string parent = FrameName(sample.parent);
  const std::string child = FrameName(sample.child);
  if (parent.empty() || child.empty() || parent == child) {
    *why = "names no frame, or the same frame twice";
    return false;
  }
  const double norm = sample.rotation.norm();
  if (!sample.translation.allFinite() || !std::isfinite(norm) || !std::isfinite(sample.stamp) ||
      std::abs(norm - 1.0) > 0.01) {
    *why = "is not a rigid motion (a non-finite value, or a quaternion far from unit length)";
    return false;
  }
  auto [at, added] = edges_.try_emplace(child);
  Edge& edge = at->second;
  if (added) {
    edge.parent = parent;
    edge.is_static = is_static;
  } else if (edge.parent != parent || edge.is_static != is_static) {
    *why = fmt::format("gives {} the parent {}, but it has {} ({}); a frame has one parent", child,
                       parent, edge.parent, edge.is_static ? "/tf_static" : "dynamic");
    return false;
  }
  frames_[parent] = true;
  frames_[child] = true;
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = sample.rotation.normalized().toRotationMatrix();
  pose.translation() = sample.translation;
  if (is_static) {  // tf2 keeps the latest static transform of a frame
    edge.samples.assign(1, {sample.stamp, pose});
    return true;
  }
  auto position = std::lower_bound(
      edge.samples.begin(), edge.samples.end(), sample.stamp,
      [](const std::pair<double, Eigen::Isometry3d>& s, double stamp) { return s.first < stamp; });
  if (position != edge.samples.end() && position->first == sample.stamp) {
    position->second = pose;  // a repeated stamp: the later message wins, as in tf2
  } else {
    edge.samples.insert(position, {sample.stamp, pose});
  }
  return true;
}

std::vector<std::string> TransformTree::Frames() const {
  std::vector<std::string> names;
  for (const auto& entry : frames_) names.push_back(entry.first);
  return names;
}

bool TransformTree::HasFrame(const std::string& frame) const {
  return frames_.count(FrameName(frame)) > 0;
}

std::vector<std::string> TransformTree::PathToRoot(const std::string& frame) const {
  std::vector<std::string> path = {frame};
  for (auto edge = edges_.find(frame); edge != edges_.end(); edge = edges_.find(path.back())) {
    if (std::find(path.begin(), path.end(), edge->second.parent) != path.end()) break;  // a cycle
    path.push_back(edge->second.parent);
  }
  return path;
}

bool TransformTree::Paths(const std::string& target, const std::string& source,
                          std::vector<std::string>* up_from_source,
                          std::vector<std::string>* up_from_target) const {
  *up_from_source = PathToRoot(source);
  *up_from_target = PathToRoot(target);
  for (size_t s = 0; s < up_from_source->size(); ++s) {
    const auto t = std::find(up_from_target->begin(), up_from_target->end(), (*up_from_source)[s]);
    if (t == up_from_target->end()) continue;
    up_from_source->resize(s + 1);  // both end at the common ancestor
    up_from_target->resize(static_cast<size_t>(t - up_from_target->begin()) + 1);
    return true;
  }
  return false;
}

std::string TransformTree::Chain(const std::string& target_name, const std::string& source_name,
                                 const std::string& where) const {
  const std::string target = FrameName(target_name), source = FrameName(source_name);
  for (const std::string& frame : {target, source}) {
    if (frames_.count(frame) > 0) continue;
    std::string known;
    for (const auto& entry : frames_) known += (known.empty() ? "" : ", ") + entry.first;
    throw InputError(fmt::format("{}: frame '{}' is not in the transform tree; its frames are: {}",
                                 where, frame, known.empty() ? "none" : known));
  }
  std::vector<std::string> up_from_source, up_from_target;
  if (!Paths(target, source, &up_from_source, &up_from_target)) {
    throw InputError(fmt::format(
        "{}: frames '{}' and '{}' lie in two trees that no transform joins (rooted at '{}' and "
        "'{}'); record the transform between them (or publish it on /tf_static)",
        where, target, source, up_from_target.back(), up_from_source.back()));
  }
  std::string chain;
  for (const std::string& frame : up_from_target) chain += (chain.empty() ? "" : " -> ") + frame;
  for (size_t i = up_from_source.size() - 1; i-- > 0;) chain += " -> " + up_from_source[i];
  return chain;
}

std::optional<Eigen::Isometry3d> TransformTree::EdgeAt(const std::string& child, const Edge& edge,
                                                       double stamp, double max_gap_s,
                                                       LookupMiss* miss) const {
  const auto& samples = edge.samples;
  if (edge.is_static) return samples.front().second;
  auto fail = [&](LookupMiss::Kind kind, double seconds) -> std::optional<Eigen::Isometry3d> {
    if (miss != nullptr) *miss = {kind, seconds, edge.parent + " -> " + child};
    return std::nullopt;
  };
  if (stamp < samples.front().first) {
    return fail(LookupMiss::Kind::kBefore, samples.front().first - stamp);
  }
  if (stamp > samples.back().first) {
    return fail(LookupMiss::Kind::kAfter, stamp - samples.back().first);
  }
  const auto upper = std::lower_bound(
      samples.begin(), samples.end(), stamp,
      [](const std::pair<double, Eigen::Isometry3d>& s, double t) { return s.first < t; });
  if (upper->first == stamp) return upper->second;
  const auto& lower = *(upper - 1);
  const double gap = upper->first - lower.first;
  if (gap > max_gap_s) return fail(LookupMiss::Kind::kGap, gap);
  return InterpolatePose(lower.second, upper->second, (stamp - lower.first) / gap);
}

std::optional<Eigen::Isometry3d> TransformTree::Lookup(const std::string& target_name,
                                                       const std::string& source_name, double stamp,
                                                       double max_gap_s, LookupMiss* miss) const {
  std::vector<std::string> up_from_source, up_from_target;
  if (!Paths(FrameName(target_name), FrameName(source_name), &up_from_source, &up_from_target)) {
    return std::nullopt;
  }
  // ancestor_from_frame for each side, composed edge by edge from the frame up.
  auto up = [&](const std::vector<std::string>& path) -> std::optional<Eigen::Isometry3d> {
    Eigen::Isometry3d ancestor_from_frame = Eigen::Isometry3d::Identity();
    for (size_t i = 0; i + 1 < path.size(); ++i) {
      const auto& edge = edges_.at(path[i]);
      const std::optional<Eigen::Isometry3d> parent_from_child =
          EdgeAt(path[i], edge, stamp, max_gap_s, miss);
      if (!parent_from_child) return std::nullopt;
      ancestor_from_frame = *parent_from_child * ancestor_from_frame;
    }
    return ancestor_from_frame;
  };
  const std::optional<Eigen::Isometry3d> ancestor_from_source = up(up_from_source);
  if (!ancestor_from_source) return std::nullopt;
  const std::optional<Eigen::Isometry3d> ancestor_from_target = up(up_from_target);
  if (!ancestor_from_target) return std::nullopt;
  return ancestor_from_target->inverse() * *ancestor_from_source;
}

std::pair<double, double> TransformTree::Span(const std::string& target,
                                              const std::string& source) const {
  std::vector<std::string> up_from_source, up_from_target;
  std::pair<double, double> span = {-HUGE_VAL, HUGE_VAL};
  if (!Paths(FrameName(target), FrameName(source), &up_from_source, &up_from_target)) return span;
  for (const auto* path : {&up_from_source, &up_from_target}) {
    for (size_t i = 0; i + 1 < path->size(); ++i) {
      const Edge& edge = edges_.at((*path)[i]);
      if (edge.is_static) continue;
      span.first = std::max(span.first, edge.samples.front().first);
      span.second = std::min(span.second, edge.samples.back().first);
    }
  }
  return span;
}

}  // namespace stillmap
