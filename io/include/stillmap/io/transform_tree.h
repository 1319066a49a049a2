// A recording's transform tree, as tf2 keeps it (issue 48): every frame has one parent; a
// dynamic edge (/tf, odometry) is interpolated between its two samples around a stamp (linear
// translation, SLERP rotation), never extrapolated; a static edge (/tf_static) holds at all
// times. Frame names are compared without a leading '/', as tf2 does.
#pragma once

#include <Eigen/Geometry>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace stillmap {

// One sample of an edge: the pose of `child` in `parent` at `stamp`.
struct TransformSample {
  std::string parent, child;
  double stamp = 0.0;  // [s]
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();
  Eigen::Quaterniond rotation = Eigen::Quaterniond::Identity();  // as recorded (x y z w)
};

// Why a lookup at a stamp found no pose: the stamp lies before an edge's first sample or after
// its last (by `seconds`), or between two samples farther apart than the gap allowed (`seconds`
// apart).
struct LookupMiss {
  enum class Kind { kBefore, kAfter, kGap } kind = Kind::kBefore;
  double seconds = 0.0;
  std::string edge;  // "parent -> child"
};

class TransformTree {
 public:
  // A frame's name as the tree keys it: without leading '/'.
  static std::string FrameName(const std::string& name);

  // Adds a sample. Returns false with *why, leaving the tree as it was, for one that is not a
  // rigid motion (a non-finite value, a quaternion off unit length by more than 1 %), names no
  // frame or one frame twice, or gives a frame a second parent (tf2 keeps one per frame).
  bool Add(const TransformSample& sample, bool is_static, std::string* why);

  // The frames known, sorted.
  std::vector<std::string> Frames() const;
  bool HasFrame(const std::string& frame) const;
  // The chain of edges from `target` to `source` through their common ancestor, as the frames
  // along it ("odom -> base_link -> camera"). Throws InputError (prefixed by `where`) when either
  // frame is not in the tree (listing the frames) or they lie in two trees (naming both roots).
  std::string Chain(const std::string& target, const std::string& source,
                    const std::string& where) const;
  // The pose of `source` in `target` at `stamp`: each dynamic edge on the chain interpolated at
  // the stamp across at most `max_gap_s`. Nothing, with *miss (may be null) saying why, when an
  // edge has no sample on both sides. Call Chain first: frames not connected give nothing.
  std::optional<Eigen::Isometry3d> Lookup(const std::string& target, const std::string& source,
                                          double stamp, double max_gap_s, LookupMiss* miss) const;
  // The stamps that every dynamic edge on the chain covers: [first, last] (-inf, inf when all are
  // static; first > last when the edges' spans do not overlap).
  std::pair<double, double> Span(const std::string& target, const std::string& source) const;

 private:
  struct Edge {
    std::string parent;
    bool is_static = false;
    std::vector<std::pair<double, Eigen::Isometry3d>> samples;  // by stamp
  };
  // The frames from `frame` up to its root, `frame` first.
  std::vector<std::string> PathToRoot(const std::string& frame) const;
  // The edges from `source` up to the common ancestor, and from `target` up to it.
  bool Paths(const std::string& target, const std::string& source,
             std::vector<std::string>* up_from_source,
             std::vector<std::string>* up_from_target) const;
  std::optional<Eigen::Isometry3d> EdgeAt(const std::string& child, const Edge& edge, double stamp,
                                          double max_gap_s, LookupMiss* miss) const;

  std::map<std::string, Edge> edges_;  // by child frame
  std::map<std::string, bool> frames_;
};

}  // namespace stillmap
