// What a keyframe adds to the map when the camera comes back (issue 27). Keyframes of one visit
// are adjusted together and fuse into the same voxels; a keyframe made on a later visit carries
// the drift between the visits, so fusing all of its view lays a second copy of the walls a few
// millimetres beside the first. Here its depth cells (16 px) that a keyframe fused on an earlier
// visit saw at the same depth, from a similar direction and distance, are left out: the seed
// paper's redundancy rule (paper 000, section II.D) applied cell by cell to revisits. A cell the
// earlier keyframe saw at another depth (a person since gone, a ghost, a moved chair) stays in.
#pragma once

#include <Eigen/Geometry>
#include <map>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "stillmap/io/camera.h"

namespace stillmap {

struct RevisitOptions {
  bool enabled = true;  // false: a keyframe on a revisit fuses all of its view
  // An earlier visit: a keyframe made at least this many keyframes before (the tracker's local
  // bundle adjustment window, tracking.local_window: keyframes nearer than that were adjusted
  // together and fuse into the same voxels).
  int keyframes_apart = 8;
  // Seen from a similar direction [deg] and distance (ratio) by the earlier keyframe: the values
  // of the tracker's keyframe culling (tracking.redundant_view_angle_deg, redundant_scale_ratio).
  double view_angle_deg = 15.0;
  double scale_ratio = 1.25;
  // A keyframe is not fused at all when earlier visits saw more than this share of its view's
  // read cells (1 = never): the rule merge.max_seen_share applies between sessions, within one
  // recording (a robot going round a floor again). Measured at 0.9 on every sequence:
  // docs/figures.md.
  double max_seen_share = 1.0;
  // A keyframe of a map segment is not fused when keyframes of the build's other segments saw
  // more than this share of its view's read cells (1 = never): whatever their keyframe ids, as
  // the merge judges sessions. Only at the final poses, once segments are joined and settled
  // (AdmitAcrossSegments). Within a segment the tracker's own culling and map reuse keep a
  // revisit's keyframes few; across segments it holds neither. Such a keyframe still adds its
  // rays, not its points (KeyframeFuser). 0.85: the floor played twice fuses 1.13x the
  // keyframes of the floor once (0.9, the merge's value: 1.22x; off: 1.80x), the maps of both
  // floor seeds and of floor_lost hold (within 0.2 point), and every room sequence, clip and
  // replay is unchanged to the byte (docs/figures.md).
  double segment_max_seen_share = 0.85;
  // With segment_max_seen_share below 1, a keyframe's own segment counts as another visit too
  // where its camera has since travelled at least this far along the segment's path [m]: a lap
  // of a floor in one segment comes back over its own ground (0 = other segments only). 10 m, the
  // one value measured: teddy played 16 times, the one room whose path is longer, drops none.
  double segment_lap_path_m = 10.0;

  // Throws InputError naming the key (keyframes.revisit_*) of the first impossible value.
  void Validate() const;

  // Every field under its configuration key (io/option_fields.h).
  template <typename Self, typename Visitor>
  static void VisitFields(Self& self, Visitor& visit) {
    visit("enabled", self.enabled,
          "a keyframe on a revisit fuses only the depth cells an earlier visit did not see");
    visit("keyframes_apart", self.keyframes_apart,
          "an earlier visit: keyframes made at least this many keyframes before (tracking's local "
          "window)");
    visit("view_angle_deg", self.view_angle_deg,
          "seen by the earlier keyframe from within this angle [deg] (tracking's culling value)");
    visit("scale_ratio", self.scale_ratio,
          "seen by the earlier keyframe from a distance within this ratio (tracking's culling "
          "value)");
    visit("max_seen_share", self.max_seen_share,
          "a keyframe is not fused when earlier visits saw more than this share of its view "
          "(1 = never)");
    visit("segment_max_seen_share", self.segment_max_seen_share,
          "a keyframe is not fused when other map segments' keyframes saw more than this share of "
          "its view, judged at the final poses (1 = never)");
    visit("segment_lap_path_m", self.segment_lap_path_m,
          "with segment_max_seen_share: its own segment's keyframes this far back along the "
          "camera's path [m] count as other segments' (0 = never)");
  }
};

// A keyframe's view in cells (DepthCells: nearest, farthest, mean depth [m], share of the cell
// read and not masked, per 16 x 16 px cell).
struct CellView {
  int keyframe_id = 0;
  Eigen::Isometry3d world_from_camera = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d camera_from_world = Eigen::Isometry3d::Identity();
  cv::Size image_size;  // of the depth it was made from [px]
  cv::Mat cells;
  double fx = 0.0, fy = 0.0, cx = 0.0, cy = 0.0;  // of the camera that made it [px]
  int segment = 0;       // the map segment of its keyframe (map_segments.h; 0 in one segment)
  double path_m = 0.0;   // how far its segment's camera had travelled at its keyframe [m]
  double reach_m = 0.0;  // the farthest its cells' points lie from the camera [m]
};

class RevisitCells {
 public:
  static constexpr int kCell = 16;           // [px]
  static constexpr float kReadCell = 0.25f;  // a cell is left out only if this share was read
  static constexpr float kFullCell = 0.9f;   // an earlier cell saw its place if this share was

  // Depth readings outside min_depth..max_depth [m] are not fused, so they count as not read
  // (BackProjectionOptions).
  RevisitCells(const Camera& camera, const RevisitOptions& options, double min_depth,
               double max_depth);

  // The view of a keyframe: depth_m (CV_32FC1 [m], 0 = none) without the pixels of `mask`
  // (CV_8UC1, non-zero = left out; or empty).
  CellView MakeView(int keyframe_id, const cv::Mat& depth_m, const cv::Mat& mask,
                    const Eigen::Isometry3d& world_from_camera, int segment = 0) const;

  // The pixels of `view` that keyframes remembered from earlier visits saw (CV_8UC1, 255 = seen,
  // whole cells), or an empty matrix when there are none.
  cv::Mat SeenBefore(const CellView& view);

  // Views made from here on come from `camera` (merged sessions of different cameras).
  void SetCamera(const Camera& camera) { camera_ = camera; }
  // The share of `view`'s read cells that `seen` (SeenBefore's answer for it) leaves out.
  static double SeenShare(const CellView& view, const cv::Mat& seen);
  // Remembers a fused keyframe's view for the keyframes after it.
  void Remember(CellView view);
  // SeenBefore, then the verdict: when the cells seen are more than options' max_seen_share of
  // `view`'s read cells, the keyframe is redundant: nullopt, and its view is not remembered. Else
  // its view is remembered and the cells seen returned (empty when none).
  std::optional<cv::Mat> Admit(CellView view);
  // Admit's verdict alone (whether the keyframe is fused; its view is then remembered), and the
  // keyframe is redundant as well when the views remembered of other map segments (or of its own,
  // segment_lap_path_m back along its path) saw more than options' segment_max_seen_share of its
  // read cells (for final poses only: the cells a keyframe leaves out were judged when it came).
  bool AdmitAcrossSegments(CellView view);
  // Frees the views remembered (no keyframe comes after).
  void Forget() { std::vector<CellView>().swap(remembered_); }

  // After a loop correction: the remembered keyframes take their poses in `world_from_keyframe`
  // (by keyframe id; others keep theirs).
  void Repose(const std::map<int, Eigen::Isometry3d>& world_from_keyframe);

  size_t cells_left_out() const { return cells_left_out_; }

 private:
  // The remembered views `take` says yes to that can have seen part of `view`: their camera
  // near enough for Covered's distance ratio and angle (an exact bound, not a guess).
  template <typename Take>
  std::vector<const CellView*> Candidates(const CellView& view, Take&& take) const;
  // The pixels of `view` whose cells `earlier` saw (whole cells, 255), and how many cells.
  cv::Mat SeenBy(const CellView& view, const std::vector<const CellView*>& earlier,
                 size_t* cells) const;
  bool CellSeenBefore(const CellView& view, int row, int column,
                      const std::vector<const CellView*>& earlier) const;
  bool Covered(const Eigen::Vector3d& point_in_world, const Eigen::Vector3d& centre,
               const CellView& other) const;

  Camera camera_;
  RevisitOptions options_;
  double min_depth_ = 0.0, max_depth_ = 0.0;  // [m]
  double min_cosine_ = 1.0;                   // of options_.view_angle_deg
  double reach_factor_ = 0.0;         // cameras' distance over the range for Covered, at most
  std::vector<CellView> remembered_;  // in keyframe order
  size_t cells_left_out_ = 0;
};

}  // namespace stillmap
