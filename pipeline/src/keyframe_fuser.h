// Keyframes into the map once their poses are final: the map re-check, keyframe selection
// (valid, not redundant) and fusion with the depth as the tracker's self-calibration has it.
#pragma once

#include <map>
#include <optional>
#include <vector>

#include "stillmap/io/sequence.h"
#include "stillmap/io/trajectory.h"
#include "stillmap/mapping/keyframe_selection.h"
#include "stillmap/mapping/mapper.h"
#include "stillmap/pipeline/build_result.h"
#include "stillmap/pipeline/config.h"
#include "stillmap/tracking/depth_correction.h"
#include "stillmap/tracking/map_recheck.h"
#include "stillmap/tracking/mask_stage.h"
#include "stillmap/tracking/tracker.h"

namespace stillmap {

class KeyframeFuser {
 public:
  // `masks` (its depth check, for the re-check) and `mapper` must outlive the fuser. The
  // re-check runs when masking, the depth check and config.map_recheck are all on.
  KeyframeFuser(const Camera& camera, const BuildConfig& config, const MaskStage& masks,
                Mapper* mapper);

  // Holds a new keyframe's images, with its mask and pose at tracking time, until it is final.
  void Hold(int keyframe_id, Frame frame, const cv::Mat& mask,
            const Eigen::Isometry3d& world_from_camera);

  // Re-checks, judges and fuses the keyframes whose poses are now final (in the order given),
  // their depth corrected by `correction`.
  void Fuse(const std::vector<FinalKeyframe>& finals, const DepthCorrection& correction);

  // The keyframes fused, with the poses they were fused at.
  const std::vector<StampedPose>& fused_poses() const { return fused_poses_; }
  SelectionFigures figures() const;
  double fuse_ms() const { return fuse_ms_; }

 private:
  struct Waiting {
    Frame frame;
    MaskReference reference;  // its mask and pose at tracking time, for the map re-check
  };
  cv::Mat Recheck(const FinalKeyframe& keyframe, std::map<int, Waiting>::iterator it,
                  bool* changed);

  Mapper& mapper_;
  std::optional<MapRecheck> recheck_;
  KeyframeSelector selector_;
  DepthFactorImages factors_;
  std::map<int, Waiting> waiting_;  // by keyframe id, i.e. in time order
  std::vector<StampedPose> fused_poses_;
  size_t recheck_additions_ = 0;
  double fuse_ms_ = 0.0;
};

}  // namespace stillmap
