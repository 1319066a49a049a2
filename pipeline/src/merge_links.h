// Where two sessions saw the same place: place recognition over one session's keyframes for each
// keyframe of the other, each candidate verified geometrically, and the verified links checked
// against each other (MergeOptions).
#pragma once

#include <Eigen/Geometry>
#include <vector>

#include "merge_sessions.h"
#include "stillmap/pipeline/merge_options.h"
#include "stillmap/tracking/place_index.h"
#include "stillmap/tracking/place_links.h"

namespace stillmap {

// A verified link: keyframe `keyframe_b` of session b seen from keyframe `keyframe_a` of session
// a (indices into the records' keyframes).
struct SessionLink {
  int keyframe_a = 0, keyframe_b = 0;
  Eigen::Isometry3d a_from_b = Eigen::Isometry3d::Identity();  // camera b in camera a's frame
  int inliers = 0;
};

struct PairLinks {
  int session_a = 0, session_b = 0;   // indices into the sessions, a < b
  int candidates = 0;                 // keyframe pairs the place index proposed
  int verified = 0;                   // of them, verified
  std::vector<SessionLink> agreeing;  // the largest set of verified links that agree
  // Where session b's map frame lies in session a's, by the link the most others agree with.
  Eigen::Isometry3d a_map_from_b_map = Eigen::Isometry3d::Identity();
  bool joined = false;  // agreeing holds at least MergeOptions::min_links links
};

// The keyframes of one session as place recognition and verification need them.
class SessionPlaces {
 public:
  SessionPlaces(const SessionRecord& record, const PlaceIndexOptions& index_options);
  const SessionRecord& record() const { return record_; }
  const PlaceIndex& index() const { return index_; }
  const LinkKeyframe& keyframe(size_t k) const { return keyframes_[k]; }

 private:
  const SessionRecord& record_;
  PlaceIndex index_;
  std::vector<LinkKeyframe> keyframes_;
};

// The link rules of a merge (merge.*).
PlaceLinkOptions LinkOptions(const MergeOptions& options);

// The links between sessions a and b (indices `a` < `b` for the result).
PairLinks FindLinks(const SessionPlaces& a, const SessionPlaces& b, int index_a, int index_b,
                    const MergeOptions& options);

}  // namespace stillmap
