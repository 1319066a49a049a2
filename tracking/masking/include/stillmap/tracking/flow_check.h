// Geometric dynamic-point check without semantics (paper 004, DGM-VINS, section III.B.2,
// Algorithm 1): points are tracked from the previous frame by pyramidal KLT flow, a fundamental
// matrix is fitted by RANSAC, and each point is described by its flow-vector length d_v and its
// distance d_l to the epipolar line of its previous position. In the (d_v, d_l) plane the points
// that move with the camera form one dense cluster; DBSCAN finds it.
#pragma once

#include <cstdint>
#include <opencv2/core.hpp>
#include <vector>

namespace stillmap {

// The KLT window when none is set. 15 px halves the flow check's time (BM_FlowCheck) and took
// bonn_crowd_a's CPU from 0.757x to 0.702x of c96d8ab's with Yolo-Fastest, masks held
// (docs/figures.md); without a detector the flow carries more of the masks, and at 15 px
// walking_xyz's grid (150 frames) has 9 cells free where the static scene is occupied against 2
// at 21 px (BuildTest's bar: 5).
constexpr int kKltWindowWithDetector = 15;
constexpr int kKltWindowGeometryOnly = 21;

// The KLT window edge [px] that `klt_window` (FlowCheckOptions) stands for: itself when set, else
// by whether a detector runs.
inline int ResolvedKltWindow(int klt_window, bool with_detector) {
  if (klt_window > 0) return klt_window;
  return with_detector ? kKltWindowWithDetector : kKltWindowGeometryOnly;
}

struct FlowCheckOptions {
  // DBSCAN in the (d_v, d_l) plane [px]. Paper 004 gives no values; these were chosen on the
  // synthetic walking sequences, frames 3 apart (flow_check_test.cpp).
  double dbscan_epsilon_px = 0.5;
  int dbscan_min_points = 6;
  // Outside the largest cluster and at least this far from the epipolar line [px]: with depth
  // parallax, static points spread along the flow-length axis and form clusters of their own,
  // but stay on their epipolar lines.
  double min_epipolar_distance_px = 2.0;
  double ransac_threshold_px = 1.0;
  double max_forward_backward_px = 0.5;
  // KLT window edge [px]; 0: by the detector (ResolvedKltWindow; MaskStage resolves it, and the
  // checks called directly take the geometry-only window).
  int klt_window = 0;
  int klt_levels = 3;

  // Every field under its configuration key (io/option_fields.h).
  template <typename Self, typename Visitor>
  static void VisitFields(Self& self, Visitor& visit) {
    visit("dbscan_epsilon_px", self.dbscan_epsilon_px,
          "DBSCAN radius in the (flow length, epipolar distance) plane [px] (paper 004)");
    visit("dbscan_min_points", self.dbscan_min_points, "DBSCAN core-point neighbours (paper 004)");
    visit("min_epipolar_distance_px", self.min_epipolar_distance_px,
          "points outside the camera's cluster flagged only this far off their epipolar line [px]");
    visit("ransac_threshold_px", self.ransac_threshold_px, "fundamental matrix inliers [px]");
    visit("max_forward_backward_px", self.max_forward_backward_px,
          "KLT tracks failing the round trip by more are dropped [px]");
    visit("klt_window", self.klt_window,
          "KLT window edge [px] (0: 15 with a detector, 21 without)");
    visit("klt_levels", self.klt_levels, "KLT pyramid levels above the image");
  }
};

struct FlowCheckResult {
  std::vector<cv::Point2f> current;   // tracked positions in the current frame
  std::vector<std::uint8_t> tracked;  // per input point: tracked both ways within the limit
  // Per input point (tracked ones only): 1 when outside the largest DBSCAN cluster. Paper 004
  // takes DBSCAN's noise as dynamic; a person moving as one body can form a dense cluster of its
  // own, so every point outside the largest (the camera's) cluster counts as dynamic here.
  std::vector<std::uint8_t> dynamic;
  std::vector<float> flow_length_px;        // d_v per input point
  std::vector<float> epipolar_distance_px;  // d_l per input point
  bool fundamental_found = false;           // false: too few tracks; nothing is flagged
};

// An image's KLT pyramid (with its derivatives), built once per frame and used as the current
// image of one check and the previous image of the next: building pyramids is about half the cost
// of the forward-backward flow.
struct FlowPyramid {
  cv::Size size;
  std::vector<cv::Mat> levels;
  bool empty() const { return levels.empty(); }
};
FlowPyramid BuildFlowPyramid(const cv::Mat& gray, const FlowCheckOptions& options = {});

FlowCheckResult CheckFlow(const FlowPyramid& previous, const FlowPyramid& current,
                          const std::vector<cv::Point2f>& previous_points,
                          const FlowCheckOptions& options = {});
FlowCheckResult CheckFlow(const cv::Mat& previous_gray, const cv::Mat& gray,
                          const std::vector<cv::Point2f>& previous_points,
                          const FlowCheckOptions& options = {});

// Up to `count` Shi-Tomasi corners at least `min_distance_px` apart, found on the half-resolution
// image and returned in full-resolution pixels (the KLT refines them at full resolution). On a
// 640x480 frame this takes about 3.5 ms against 12-22 ms at full resolution
// (cv::goodFeaturesToTrack, measured on bonn_crowd_a; stillmap_masking_benchmark).
std::vector<cv::Point2f> FlowCorners(const cv::Mat& gray, int count, double min_distance_px);

// The image-only part of the flow check over a stream of frames, taken in order: each frame's
// pyramid, the check of the previous frame's corners against it, and its own corners for the
// next frame. It needs nothing from tracking, so a pipeline may run it ahead, on the thread that
// decodes the frames.
struct FlowStep {
  std::vector<cv::Point2f> from;  // the previous frame's corners (empty on the first frame)
  FlowCheckResult result;         // their check against this frame
  double ms = 0.0;                // time taken
};

class FlowTracker {
 public:
  FlowTracker(int corners, const FlowCheckOptions& options)
      : corners_(corners), options_(options) {}
  FlowStep Next(const cv::Mat& gray);

 private:
  int corners_;
  FlowCheckOptions options_;
  FlowPyramid previous_pyramid_;
  std::vector<cv::Point2f> previous_corners_;
};

// DBSCAN over 2-D points: a cluster label per point (0, 1, ...) or -1 for noise.
std::vector<int> Dbscan(const std::vector<cv::Point2f>& points, double epsilon, int min_points);

}  // namespace stillmap
