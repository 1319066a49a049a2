// Fusion of the semantic prior and the geometric checks into one mask of moving pixels per frame
// (issue 5; paper 000 section II.C, paper 002 section III, paper 004 section III.B).
//
// Geometry finds what moves, whatever it is:
//  - the multi-view depth check of paper 002, densified: depth pixels of reference keyframes
//    (sampled every few pixels, their own moving pixels left out) are placed in 3-D, moved into
//    the current camera and splatted into a "static depth" image, the nearest surface the
//    references saw along each ray. A current reading nearer than that by more than tau_d (0.4 m,
//    paper 002) is a seed; points seen under more than 30 degrees of parallax are skipped;
//  - the flow check of paper 004 (KLT, RANSAC fundamental matrix, DBSCAN): points outside the
//    camera's cluster are seeds where the references saw nothing (the depth check is the more
//    reliable of the two where both apply).
// Seeds grow into regions over depth-continuous pixels that are also nearer than the static depth
// by a lower threshold (hysteresis), or that no reference saw (for a bounded number of steps).
//
// Semantics says what may move: each detection is cut from its box to the object's outline (the
// detection's own segment for DeepLab; for boxes the depth-continuous foreground, Canny-bounded
// regions, or the whole box). High-level objects (people, animals) are masked whether or not
// geometry confirms them; medium-level ones (chairs, books...) only when geometry finds them
// moving; geometric regions outside every detection (a carried object) are masked too. The union
// is closed, stripped of specks and dilated by a safety margin.
#pragma once

#include <Eigen/Geometry>
#include <deque>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "stillmap/io/camera.h"
#include "stillmap/tracking/depth_check.h"
#include "stillmap/tracking/detector.h"
#include "stillmap/tracking/flow_check.h"

namespace stillmap {

enum class OutlineMode { kBox, kDepth, kEdges };
// "box", "depth" or "edges"; throws InputError listing them otherwise.
OutlineMode ParseOutlineMode(const std::string& name);
const char* OutlineModeName(OutlineMode mode);

// The flow check's corners when none are set: fewer with a detector, which carries the masks;
// without one the flow carries more of them (docs/figures.md, ninth session).
constexpr int kFlowPointsWithDetector = 300;
constexpr int kFlowPointsGeometryOnly = 400;

// The corner count that `flow_points` (DynamicMaskOptions) stands for: itself when set, else by
// whether a detector runs.
inline int ResolvedFlowPoints(int flow_points, bool with_detector) {
  if (flow_points > 0) return flow_points;
  return with_detector ? kFlowPointsWithDetector : kFlowPointsGeometryOnly;
}

// The least unclaimed region outlined when none is set: with a detector, a person it missed
// (close to the lens, cut by the image's edge); without one every person is unclaimed, and their
// widened box costs the masks' precision (docs/figures.md, fifty-eighth session).
constexpr int kUnclaimedOutlineMinPxWithDetector = 20000;

// The least size that `unclaimed_outline_min_px` (DynamicMaskOptions) stands for: itself when
// set (0: off), else by whether a detector runs.
inline int ResolvedUnclaimedOutlineMinPx(int min_px, bool with_detector) {
  if (min_px >= 0) return min_px;
  return with_detector ? kUnclaimedOutlineMinPxWithDetector : 0;
}

struct DynamicMaskOptions {
  bool semantics = true;
  bool depth_check = true;  // paper 002's multi-view depth check
  bool flow_check = true;   // paper 004's flow / epipolar clustering
  DepthCheckOptions depth;  // tau_d = 0.4 m and 30 degrees of parallax (paper 002): seeds
  FlowCheckOptions flow;
  // Corners tracked from the previous frame for the flow check; 0: by the detector
  // (ResolvedFlowPoints; MaskStage resolves it, and a masker built directly takes the
  // geometry-only count).
  int flow_points = 0;

  int reference_keyframes = 3;  // the last keyframe and older ones, spread in time
  double reference_spacing_s = 0.7;
  // Current pixels are judged in blocks of stride x stride: one verdict for the readings
  // continuous with the block's centre, the others (object edges) each on their own.
  int depth_check_stride = 4;
  double grow_depth_difference_m = 0.1;  // hysteresis: grown pixels nearer than the static
                                         // depth by this plus 6 sigma of Kinect noise
  double continuity = 0.03;
  // The growth's noise margin: grow_depth_difference_m + this many sigmas of Kinect depth noise.
  double grow_noise_sigmas = 6.0;
  // A seed must lie nearer than the reference by more than this many growth margins too: beyond
  // about 3.4 m twice the margin exceeds tau_d.
  double seed_noise_factor = 2.0;
  // A reading shares its depth-check block's verdict when within 1 cm + this share of depth of
  // the block's centre reading.
  double block_continuity = 0.01;
  // Growth through pixels no reference saw [px]: a person whose place the references never saw
  // free is covered only this far from the seeds (farther, it runs into the floor).
  int max_unknown_steps = 45;

  OutlineMode outline = OutlineMode::kDepth;  // box detections: how the object is cut out
  // kDepth: readings in the foreground's depth band anywhere in the box seed the outline, not
  // only those in its centre, unless the depth check confirms them static (arms and a far leg
  // parted from the torso by background); unconfirmed seeds everywhere in the box would take
  // in desks and the floor at the feet.
  bool outline_whole_box = true;
  // A moving region the geometry finds, that no detection's outline touches, of at least this
  // many pixels is outlined as a detected person is (0: off; -1: by the detector,
  // ResolvedUnclaimedOutlineMinPx, which MaskStage resolves), in its box widened by
  // unclaimed_outline_widen of its width on each side: a person no detector boxes (close to the
  // lens, cut by the image's edge) whose arms and chest the depth check misses while they walk
  // ahead at the camera's pace. Readings the depth check confirms static stay out.
  int unclaimed_outline_min_px = -1;
  double unclaimed_outline_widen = 0.25;
  double medium_min_moving_share = 0.1;  // medium-level: share of the outline geometry marks
  // A high-level object that geometry has never seen move, and whose outline the depth check
  // confirms static for at least this share of it, is left unmasked: a still object the detector
  // takes for a person (a teddy bear). A person who walked and stopped stays masked.
  double high_static_share = 0.5;
  // The detector runs every n-th frame; boxes are carried between by the flow of their points.
  int detector_interval = 2;
  // The detector runs on its own thread, off the tracking path, its detections used
  // detector_interval frames later, carried there by flow (issue 17; needs --threads >= 2).
  bool detector_in_background = true;
  // A detector with a second opinion (yolo-fastest+yolox) asks it where the first one is weak
  // (DynamicMasker::WantsSecondOpinion), on at most this share of its runs, counted from the
  // first (issue 51: YOLOX adds about 40 ms of CPU to a run).
  double second_opinion_share = 0.15;
  // A person (high level) the detector found in two runs in a row is kept, carried by flow,
  // through this many later runs that miss it while the middle of its box still holds something
  // at the depth it was seen at (a missed detection is not a person leaving, and one who stands
  // still is found by semantics only). The two-runs rule keeps out one-off detections (YOLOX
  // now and then takes the teddy bear for a person).
  int detection_memory_runs = 2;
  int margin_px = 1;
  int min_region_px = 150;

  // How far back references are kept: long enough to pick reference_keyframes of them spread
  // reference_spacing_s apart [s].
  double ReferenceHorizonS() const {
    return reference_spacing_s * static_cast<double>(reference_keyframes) + 0.5;
  }

  // Throws InputError naming the first impossible value.
  void Validate() const;
  // Flow is tracked (for the flow check, or to carry detections between detector runs).
  bool TracksFlow() const { return flow_check || semantics; }

  // Every field under its configuration key (io/option_fields.h).
  template <typename Self, typename Visitor>
  static void VisitFields(Self& self, Visitor& visit) {
    visit("semantics", self.semantics, "use the detector's detections");
    visit("depth_check", self.depth_check, "multi-view depth check against keyframes (paper 002)");
    visit("flow_check", self.flow_check, "KLT flow / epipolar distance DBSCAN check (paper 004)");
    visit.Nested("", self.depth);
    visit.Nested("flow_", self.flow);
    visit("flow_points", self.flow_points,
          "corners tracked for the flow check (0: 300 with a detector, 400 without)");
    visit("reference_keyframes", self.reference_keyframes,
          "keyframes the depth check compares with");
    visit("reference_spacing_s", self.reference_spacing_s,
          "older references at least this far apart [s]");
    visit("depth_check_stride", self.depth_check_stride,
          "depth check: one verdict per n x n block of continuous readings");
    visit("grow_depth_difference_m", self.grow_depth_difference_m,
          "regions grow over pixels nearer than the static depth by this [m] (+ noise)");
    visit("continuity", self.continuity,
          "neighbours within 1 cm + this share of depth are one surface");
    visit("grow_noise_sigmas", self.grow_noise_sigmas,
          "growth margin: grow_depth_difference_m + this many sigmas of Kinect noise");
    visit("seed_noise_factor", self.seed_noise_factor,
          "seeds lie nearer by more than this many growth margins");
    visit("block_continuity", self.block_continuity,
          "a reading takes its check block's verdict within 1 cm + this share of depth");
    visit("max_unknown_steps", self.max_unknown_steps,
          "growth through pixels no reference saw [px] (0..255)");
    visit("outline", self.outline,
          "box detections cut to: depth (foreground), edges (Canny, paper 000), box");
    visit("outline_whole_box", self.outline_whole_box,
          "depth outline seeded anywhere in the box, not only its centre, where not confirmed "
          "static");
    visit("unclaimed_outline_min_px", self.unclaimed_outline_min_px,
          "moving regions outside every detection of at least this size [px] are outlined as a "
          "detected person is (0: off; -1: 20000 with a detector, off without)");
    visit("unclaimed_outline_widen", self.unclaimed_outline_widen,
          "their box widened by this share of its width on each side (arms parted from the "
          "torso)");
    visit("medium_min_moving_share", self.medium_min_moving_share,
          "medium-level objects are masked when geometry marks this share of them");
    visit("high_static_share", self.high_static_share,
          "a person never seen moving is left unmasked when the depth check confirms this "
          "share of it static");
    visit("detector_interval", self.detector_interval,
          "run the detector every n-th frame (boxes carried between by flow)");
    visit("second_opinion_share", self.second_opinion_share,
          "yolo-fastest+yolox: at most this share of detector runs also ask yolox (0..1)");
    visit("detection_memory_runs", self.detection_memory_runs,
          "a person is kept through this many detector runs that miss it");
    visit("detector_in_background", self.detector_in_background,
          "detector on its own thread, its detections used detector_interval frames later");
    visit("margin_px", self.margin_px, "safety margin around moving objects [px]");
    visit("min_region_px", self.min_region_px,
          "geometric regions smaller than this are dropped [px]");
  }
};

// Detections moved from the previous frame to this one by the median flow of the points `flow`
// tracked inside each (at least 3; others stay), their masks clipped to the image of `size`.
void CarryDetections(const FlowStep& flow, const cv::Size& size,
                     std::vector<Detection>* detections);

// A keyframe as a reference for the depth check.
struct MaskReference {
  double time = 0.0;
  cv::Mat depth_m;  // CV_32FC1
  cv::Mat mask;     // CV_8UC1 moving pixels (left out), or empty
  Eigen::Isometry3d world_from_camera = Eigen::Isometry3d::Identity();
  // NearestStaticDepth(*this), cached by DynamicMasker; computed on the fly when empty.
  cv::Mat nearest_depth_m;
  int keyframe_id = -1;  // the tracker's, for poses corrected later (DynamicMasker::Repose)
};

// The reference's depth with its moving pixels removed, as the minimum over 5x5 pixels (0 where
// any of them has no reading): one-pixel pose or edge errors at thin objects are no evidence.
cv::Mat NearestStaticDepth(const MaskReference& reference);

// From references sorted newest first: the newest, then each next one at least spacing_s older
// than the last chosen, at most `count`.
std::vector<const MaskReference*> SpreadInTime(
    const std::vector<const MaskReference*>& newest_first, double spacing_s, size_t count);

struct DynamicMaskResult {
  cv::Mat mask;              // CV_8UC1, 255 = moving
  double share = 0.0;        // masked share of the image
  int depth_seeds = 0;       // pixels the depth check flagged
  int flow_seeds = 0;        // flow-check points used as seeds
  int geometric_pixels = 0;  // after growth
  int high_regions = 0;
  int high_confirmed = 0;  // of those, with geometry agreeing
  int medium_moving = 0;
  int medium_static = 0;
  int high_static = 0;             // high-level, never seen moving, confirmed static: not masked
  int geometric_only_regions = 0;  // moving regions outside every detection
  int geometric_outlined = 0;      // of them, outlined as a detected person is
  bool detections_fresh = false;   // the detector ran on this frame (else carried or none)
  double ms = 0.0;
};

// Depth-check seeds and their growth for one frame against references. Used online and when a
// keyframe is fused into the map, against its neighbours on both sides in time.
class GeometricMasker {
 public:
  GeometricMasker(const Camera& camera, const DynamicMaskOptions& options);
  // CV_8UC1, 255 = moving. `extra_seeds` (flow check) count only where no reference saw the
  // static surface or where the depth check's lower threshold agrees. `depth_seeds` (optional)
  // receives the number of depth-check seed pixels.
  // `consistent` (optional) receives CV_8UC1, 255 where a reference confirms the reading as
  // static.
  cv::Mat Compute(const cv::Mat& depth_m, const Eigen::Isometry3d& world_from_camera,
                  const std::vector<const MaskReference*>& references,
                  const std::vector<cv::Point>& extra_seeds = {}, int* depth_seeds = nullptr,
                  cv::Mat* consistent = nullptr) const;

 private:
  Camera camera_;
  DynamicMaskOptions options_;
  std::vector<Eigen::Vector2f> rays_;  // undistorted normalized ray per pixel
};

// Pixels of an earlier keyframe that a later one found moving (DynamicMasker::AddReference): a
// person who has moved on since, left unmasked when the keyframe was made.
struct FoundMoving {
  int keyframe_id = -1;
  cv::Mat moving;  // CV_8UC1, 255 = found moving (the keyframe's image size)
};

class DynamicMasker {
 public:
  DynamicMasker(const Camera& camera, const DynamicMaskOptions& options);

  // The mask of one frame. `world_from_camera`: its (predicted) pose, or nothing (no depth
  // check). `detections`: this frame's, or nullptr on frames the detector skipped (the last ones
  // are carried by the flow of their points).
  // `flow`: this frame's step of a FlowTracker run by the caller (for example ahead, on another
  // thread), or nullptr to let the masker run its own; either way every frame must pass through
  // the same tracker, in order.
  DynamicMaskResult Compute(const cv::Mat& gray, const cv::Mat& depth_m,
                            const std::optional<Eigen::Isometry3d>& world_from_camera,
                            const std::vector<Detection>* detections,
                            const FlowStep* flow = nullptr);

  // A keyframe becomes a depth-check reference (kept: the newest and older ones spread in time).
  // Returns what it found moving in the older references (their masks grow by it).
  std::vector<FoundMoving> AddReference(MaskReference reference);
  // Frees the references (after the last frame).
  void ForgetReferences() { std::deque<MaskReference>().swap(references_); }

  // References whose keyframe has a pose here take it (after a loop correction moved them).
  void Repose(const std::map<int, Eigen::Isometry3d>& world_from_keyframe);

  // The references Compute uses now, newest first.
  std::vector<const MaskReference*> References() const;
  const GeometricMasker& geometry() const { return geometry_; }

  // Whether the detector's next run should ask its second opinion, from the last frame: a person
  // near the lens (a box over a third of the image), one lost at the image border (kept from
  // memory), or moving pixels outside every box (a region of 1 % of the image at its left or
  // right tenth, or of 2 % anywhere): where a fast detector misses people.
  bool WantsSecondOpinion() const { return wants_second_opinion_; }

 private:
  std::vector<cv::Point> FlowSeeds(const FlowStep& flow, const cv::Mat& depth_m,
                                   std::vector<cv::Point2f>* moved_from,
                                   std::vector<cv::Point2f>* moved_to) const;

  Camera camera_;
  DynamicMaskOptions options_;
  GeometricMasker geometry_;
  std::deque<MaskReference> references_;  // newest first
  FlowTracker flow_tracker_;              // used when Compute is given no flow step
  std::vector<Detection> carried_;
  bool wants_second_opinion_ = false;
};

// Pixel precision, recall and IoU of `mask` against `truth` (both CV_8UC1, non-zero = moving),
// accumulated over frames.
struct MaskScore {
  double true_positive = 0.0;
  double false_positive = 0.0;
  double false_negative = 0.0;
  double iou_sum = 0.0;  // per-frame IoU, summed over frames with moving pixels in either
  size_t frames = 0;
  void Add(const cv::Mat& mask, const cv::Mat& truth);
  double Precision() const;
  double Recall() const;
  double Iou() const;  // pooled over all pixels
  double MeanFrameIou() const;
};

}  // namespace stillmap
