// The camera's up on its mount from the floor the map's keyframes saw in depth (floor_normal.h),
// for the plane of motion (tracking.planar_motion).
#pragma once

#include <Eigen/Core>

#include "keyframe_fuser.h"
#include "segment_keeper.h"
#include "stillmap/io/camera.h"
#include "stillmap/pipeline/build_result.h"
#include "stillmap/tracking/floor_normal.h"

namespace stillmap {

// The floor's normal in the map's keyframes kept compact (at most options.max_keyframes of them,
// spread evenly), found about `tracked_up_in_camera`; `up_in_camera` gets their median direction
// when at least options.min_keyframes saw the floor (FloorUpFigures::taken), else stays.
FloorUpFigures UpFromFloor(const Camera& camera, const KeyframeFuser& fuser,
                           const SegmentKeeper& segments, const FloorNormalOptions& options,
                           Eigen::Vector3d* up_in_camera);

}  // namespace stillmap
