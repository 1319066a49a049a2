// Keyframes into the map once their poses are final: the map re-check, keyframe selection
// (valid, not redundant) and fusion with the depth as the tracker's self-calibration has it.
#pragma once

#include <functional>
#include <map>
#include <optional>
#include <vector>

#include "stillmap/io/sequence.h"
#include "stillmap/io/session_keyframes.h"
#include "stillmap/io/session_record.h"
#include "stillmap/io/spill_file.h"
#include "stillmap/io/trajectory.h"
#include "stillmap/mapping/keyframe_selection.h"
#include "stillmap/mapping/mapper.h"
#include "stillmap/mapping/revisit_cells.h"
#include "stillmap/pipeline/build_result.h"
#include "stillmap/tracking/depth_correction.h"
#include "stillmap/tracking/map_recheck.h"
#include "stillmap/tracking/mask_stage.h"
#include "stillmap/tracking/tracker.h"

namespace stillmap {

// What the fuser reads of the build's configuration.
struct FuserOptions {
  bool keep_for_refusion = true;  // tracking.loop_closure: fused keyframes may move
  bool keep_for_session = true;   // map.session_record
  bool recheck = true;            // masking.map_recheck (with masking and its depth check on)
  DynamicMaskOptions masking;     // the re-check's depth check
  KeyframeSelectionOptions selection;
  double min_depth_m = 0.0, max_depth_m = 0.0;  // the back-projection's range
};

class KeyframeFuser {
 public:
  // `masks` (its depth check, for the re-check) and `mapper` must outlive the fuser. The
  // re-check runs when masking, its depth check and options.recheck are all on.
  KeyframeFuser(const Camera& camera, const FuserOptions& options, const MaskStage& masks,
                Mapper* mapper);

  // Holds a new keyframe's images, with its mask and pose at tracking time, until it is final.
  void Hold(int keyframe_id, Frame frame, const cv::Mat& mask,
            const Eigen::Isometry3d& world_from_camera);

  // Re-checks, judges and fuses the keyframes whose poses are now final (in the order given),
  // their depth corrected by `correction`. A keyframe `in_map` says no to (a map segment not
  // joined to the first: map_segments.h) is judged the same but kept apart, compact, instead.
  // `segment_of` names each keyframe's map segment (all in segment 0 without it).
  void Fuse(const std::vector<FinalKeyframe>& finals, const DepthCorrection& correction,
            const std::function<bool(int keyframe_id)>& in_map = nullptr,
            const std::function<int(int keyframe_id)>& segment_of = nullptr);
  // Fuses the keyframes kept apart that `in_map` now says yes to (their segment was joined), at
  // their poses in `world_from_keyframe`. Returns how many.
  size_t FuseJoined(const std::function<bool(int keyframe_id)>& in_map,
                    const std::map<int, Eigen::Isometry3d>& world_from_keyframe);
  // Hands over the keyframes kept apart that `take` says yes to, in the session record's form
  // (poses in the tracker's world, features always kept).
  SessionKeyframeList TakeApart(const std::function<bool(int keyframe_id)>& take);

  // After loop corrections: when a fused keyframe's pose in `world_from_keyframe` (by keyframe
  // id) differs from the one it was fused at (by more than 1 mm or 0.05 degrees), the map is
  // emptied and every fused keyframe fused again at its final pose, from the compact copies kept
  // since (masked, corrected depth as a 16-bit PNG, colour as a JPEG, parked in a temporary file:
  // spill_file.h). Keyframes waiting since NoteCorrections or NoteNewSegment are fused either
  // way (when nothing moved, onto the map fused before them). With
  // keyframes.revisit_segment_max_seen_share below 1, every keyframe fused here is judged again at
  // its final pose (RevisitCells::AdmitAcrossSegments: whether other map segments, or its own a
  // lap back, saw its view): a keyframe found redundant leaves the cloud and the session record,
  // and only its rays go into the map (they clear what moved away); the others fuse as they were
  // judged when they came. Returns how many moved.
  size_t Refuse(const std::map<int, Eigen::Isometry3d>& world_from_keyframe);
  // After poses were corrected (a loop, a global adjustment, a segment's join or settle): once a
  // fused keyframe has moved, Refuse will fuse every keyframe again, so fusing into the map until
  // then is work thrown away. The map is emptied now and keyframes are only kept, compact, until
  // Refuse fuses them all (the same map, sooner: docs/figures.md). Only when every fused keyframe
  // is kept (refusion or session record).
  void NoteCorrections(const std::map<int, Eigen::Isometry3d>& world_from_keyframe);
  // A new map segment began (tracking lost): its joins and their settles will most likely move
  // the keyframes fused so far, so keyframes from here on are only kept until Refuse, which fuses
  // them where they end up; the map fused so far stays until a correction moves it.
  void NoteNewSegment();
  // After the last keyframe, before Refuse: what only new keyframes need (the map re-check's
  // references, the cells of the views remembered for revisits) is freed.
  void EndKeyframes();
  // Whether the map waits for Refuse (NoteCorrections).
  bool refusion_due() const { return refusion_due_; }

  // The fused keyframes in the session record's form (poses as fused, in the tracker's world),
  // handed over once at the end: empty when the build keeps no session record.
  SessionKeyframeList TakeSessionKeyframes();

  // A kept keyframe as the final pose refinement reads it (dense_refinement.h).
  struct KeptKeyframe {
    int keyframe_id = 0;
    double time = 0.0;
    bool apart = false;  // kept apart: not in the map
    Eigen::Isometry3d world_from_camera = Eigen::Isometry3d::Identity();  // as kept
  };
  // Every keyframe kept compact, in the order they came.
  std::vector<KeptKeyframe> KeptKeyframes() const;
  // The `index`th kept keyframe's gray image and depth [m] (moving pixels 0), decoded.
  void ImagesOf(size_t index, cv::Mat* gray, cv::Mat* depth_m) const;

  // The keyframes fused, with the poses they were fused at.
  const std::vector<StampedPose>& fused_poses() const { return fused_poses_; }
  SelectionFigures figures() const;
  double depth_unit_m() const { return depth_unit_m_; }  // of the kept depth PNGs
  double fuse_ms() const { return fuse_ms_; }
  double refuse_ms() const { return refuse_ms_; }
  // What the compact copies hold in memory, and in their temporary file [bytes].
  size_t stored_bytes() const;
  std::uint64_t parked_bytes() const { return parked_->size(); }
  // The images of the keyframes held until their poses are final [bytes].
  size_t held_bytes() const;

 private:
  struct Waiting {
    Frame frame;
    MaskReference reference;  // its mask and pose at tracking time, for the map re-check
  };
  cv::Mat Recheck(const FinalKeyframe& keyframe, std::map<int, Waiting>::iterator it,
                  bool* changed);

  // A fused keyframe in compact form, for Refuse, its blocks in parked_.
  struct Stored {
    int keyframe_id = 0;
    double time = 0.0;
    Eigen::Isometry3d world_from_camera = Eigen::Isometry3d::Identity();
    SpillFile::Block depth_png;   // CV_16UC1 in depth_unit_m_, 0 = none or moving
    SpillFile::Block seen_png;    // CV_8UC1 cells seen on an earlier visit, or empty
    SpillFile::Block color_jpeg;  // BGR
    SpillFile::Block features;    // for the session record (AppendSessionFeatures), or empty
    size_t feature_count = 0;
    bool apart = false;         // kept apart: not in the map (Fuse's in_map)
    bool in_map = false;        // fused into the map as it is now
    bool rays_only = false;     // redundant at the final poses: its rays alone, no session record
    int segment = 0;            // its map segment (Fuse's segment_of)
    size_t cells_left_out = 0;  // of its view, seen on an earlier visit (RevisitCells)
  };
  // Adds `stored` to `list` (its blocks stay where they are).
  static void AddTo(const Stored& stored, SessionKeyframeList* list);
  // Keeps `input` (its mask: what moves) with the cells `seen` on earlier visits apart.
  Stored& Store(const FinalKeyframe& keyframe, const MapperFrame& input, const cv::Mat& seen,
                int segment, bool apart = false);
  // Whether every keyframe fused is also kept, compact (for Refuse or the session record).
  bool KeepsEveryFused() const { return keep_for_refusion_ || keep_for_session_; }
  // Whether keyframes are fused into the map as they come (not waiting for Refuse).
  bool FusingLive() const { return !refusion_due_ && !deferring_; }
  // Whether `stored` was fused elsewhere than at `world_from_camera` (1 mm, 0.05 degrees).
  static bool Moved(const Stored& stored, const Eigen::Isometry3d& world_from_camera);
  // A stored keyframe as the mapper takes it; `depth_m`, when given, is its DepthOf already read.
  MapperFrame Decode(const Stored& stored, cv::Mat depth_m = {}) const;
  // Its rays alone (MapperFrame::rays_only): its depth (DepthOf) and pose, every pixel.
  static MapperFrame RaysOf(const Stored& stored, cv::Mat depth_m);
  // Its depth [m] alone (moving pixels 0).
  cv::Mat DepthOf(const Stored& stored) const;
  // Fuses a judged keyframe into the map (the cells earlier visits saw left out), kept compact
  // when the build may fuse it again or records the session.
  void FuseNow(const FinalKeyframe& keyframe, MapperFrame input, int segment);
  // Refuse's fusion when keyframes wait for it: each keyframe judged again at its final pose
  // (`again`: the map was emptied, every keyframe is fused; else those not in the map yet).
  void FuseAtFinalPoses(bool again);
  // How far each stored keyframe's segment had travelled at it [m], by keyframe id: along the
  // segment's keyframes in id order, at their current poses.
  std::map<int, double> PathsAlongSegments() const;
  // Counts `stored` among the keyframes not fused (earlier visits saw their view) or takes it back.
  void SetRedundant(Stored* stored, bool redundant);
  // Fuses a stored keyframe kept apart, now joined, at its pose. False when it is redundant
  // (Revisit): then it is neither fused nor to be kept.
  bool FuseStored(Stored* stored);
  // The depth cells of `input` that fused keyframes of earlier visits saw (RevisitCells), empty
  // when none; nullopt when they are more than keyframes.revisit_max_seen_share of its view: the
  // keyframe is redundant, not fused. `cells_left_out` gets how many cells it leaves out (0 when
  // redundant), which the fuser's count takes too.
  std::optional<cv::Mat> Revisit(int keyframe_id, const MapperFrame& input, size_t* cells_left_out);

  Mapper& mapper_;
  bool keep_for_refusion_ = false;  // loop closure may move fused keyframes
  bool keep_for_session_ = false;   // the build writes a session record
  double depth_unit_m_ = 0.0;
  std::shared_ptr<SpillFile> parked_;
  std::vector<Stored> stored_;
  double refuse_ms_ = 0.0;
  bool refusion_due_ = false;    // the map was emptied: keyframes are kept until Refuse
  bool judge_segments_ = false;  // keyframes.revisit_segment_max_seen_share < 1
  bool deferring_ = false;       // keyframes are kept until Refuse (NoteNewSegment)
  std::optional<MapRecheck> recheck_;
  KeyframeSelector selector_;
  RevisitCells revisits_;
  size_t seen_before_ = 0;     // keyframes not fused: earlier visits saw their view
  size_t cells_left_out_ = 0;  // of the keyframes fused, seen on earlier visits
  DepthFactorImages factors_;
  std::map<int, Waiting> waiting_;  // by keyframe id, i.e. in time order
  std::vector<StampedPose> fused_poses_;
  size_t recheck_additions_ = 0;
  double fuse_ms_ = 0.0;
};

}  // namespace stillmap
