#include "report_tracking.h"

#include <algorithm>

#include "stillmap/io/option_names.h"

namespace stillmap {
namespace {

using nlohmann::json;

json DepthCalibrationJson(const TrackerStatistics& t, const TrackerOptions& options) {
  if (!options.matching.depth_self_calibration) return {{"enabled", false}};
  const auto& p = t.depth_correction.coefficients;
  const DepthCorrectionFit& last = t.last_depth_calibration;
  return {{"enabled", true},
          {"model", "z_true = z (1 + p1 x + p2 y + p3 x^2 + p4 y^2 + p5 x y), x, y normalized"},
          {"coefficients", {p[0], p[1], p[2], p[3], p[4]}},
          {"fits_accepted", t.depth_calibrations},
          {"fits_refused", t.depth_calibrations_refused},
          {"last_fit",
           {{"accepted", last.ok},
            {"pairs", last.pairs},
            {"pairs_used", last.pairs_used},
            {"spread_before_m", last.spread_before_m},
            {"spread_after_m", last.spread_after_m}}}};
}

// Each corrected loop: when, to which earlier time, by how much.
json LoopsJson(const std::vector<CorrectedLoop>& loops) {
  json out = json::array();
  for (const CorrectedLoop& loop : loops) {
    out.push_back({{"time_s", loop.time},
                   {"earlier_time_s", loop.earlier_time},
                   {"correction_m", loop.correction_m},
                   {"correction_deg", loop.correction_deg}});
  }
  return out;
}

// The smallest, 5th-percentile and median share over the frames.
json ShareJson(std::vector<double> shares) {
  if (shares.empty()) return nullptr;
  std::sort(shares.begin(), shares.end());
  return {{"min", shares.front()},
          {"p5", shares[shares.size() / 20]},
          {"median", shares[shares.size() / 2]}};
}

// tracking.planar_motion: the plane of motion, how far the tracked poses were from it, and
// whether the final poses were put on it.
json PlanarMotionJson(const TrackingFigures& tracking, const TrackerOptions& options) {
  json out = {{"mode", PlanarMotionModeName(options.planar_motion)},
              {"applied", tracking.planar_motion_applied}};
  if (options.planar_motion == PlanarMotionMode::kOff) return out;
  out["refused"] = tracking.planar_motion_refused;  // the camera turned too little
  if (!tracking.planar_motion) return out;
  const PlanarMotion& plane = *tracking.planar_motion;
  const auto vector = [](const Eigen::Vector3d& v) { return json{v.x(), v.y(), v.z()}; };
  out["kept_to_plane"] = KeptToPlane(plane);  // within a robot's spreads ("auto" applies it)
  out["up_in_first_camera"] = vector(plane.up_in_world);  // the tracking world
  out["up_in_camera"] = vector(plane.up_in_camera);
  out["height_m"] = plane.height_m;
  out["tracked_height_spread_m"] = plane.height_spread_m;
  out["tracked_tilt_spread_deg"] = plane.tilt_spread_deg;
  out["tracked_height_median_deviation_m"] = plane.height_median_deviation_m;  // "auto" reads
  out["tracked_tilt_median_deviation_deg"] = plane.tilt_median_deviation_deg;  // these two
  out["heading_spread"] = plane.heading_spread;
  if (tracking.planar_floor) {  // up_in_camera is the floor's where taken
    const FloorUpFigures& floor = *tracking.planar_floor;
    out["tilt_from_floor"] = {{"keyframes_read", floor.keyframes_read},
                              {"keyframes_seeing_floor", floor.keyframes_seeing_floor},
                              {"taken", floor.taken},
                              {"tracked_up_in_camera", vector(floor.tracked_up_in_camera)},
                              {"change_deg", floor.change_deg},
                              {"spread_deg", floor.spread_deg}};
  }
  return out;
}

// New maps lost again before a keyframe of theirs was kept: their frames are counted as lost.
json LostAgainJson(const std::vector<SegmentSummary>& lost_again) {
  json out = json::array();
  for (const SegmentSummary& s : lost_again) {
    out.push_back({{"first_time", s.first_time}, {"last_time", s.last_time}, {"frames", s.frames}});
  }
  return out;
}

json TrackerJson(const TrackingFigures& tracking, const TrackerOptions& options) {
  const TrackerStatistics& t = tracking.statistics;
  return {{"frames", t.frames},
          {"tracked", t.tracked},
          {"lost", t.lost},
          {"relocalized", t.relocalized},
          {"new_maps", t.new_maps},
          {"new_maps_lost_again", LostAgainJson(tracking.lost_again)},
          {"status_counts", tracking.status_counts},
          {"lost_frame_times", tracking.lost_times},
          {"occluded", t.occluded},
          {"predicted", t.predicted},
          {"flagged_frame_times", tracking.flagged_times},
          {"relocalizations_refused", t.relocalizations_refused},
          {"jumps_refused", t.jumps_refused},
          {"rgbd_odometry",
           {{"posed", t.rgbd_posed},
            {"refused", t.rgbd_refused},
            {"feature_poses_checked", t.rgbd_checked},
            {"feature_poses_replaced", t.rgbd_replaced},
            {"dense_poses_unconfirmed", t.rgbd_unconfirmed}}},
          {"static_depth_share", ShareJson(tracking.static_depth_share)},
          {"keyframes", t.keyframes},
          {"keyframes_culled", t.keyframes_culled},
          {"landmarks_alive", t.landmarks},
          {"landmarks_merged", t.landmarks_merged},
          {"loops",
           {{"candidates", t.loop_candidates},
            {"verified", t.loops_verified},
            {"accepted", t.loops_accepted},
            {"rejected", t.loops_rejected},
            {"refused_implausible_drift", t.loops_implausible},
            {"largest_correction_m", t.loop_correction_m},
            {"largest_correction_deg", t.loop_correction_deg},
            {"corrected", LoopsJson(t.loops_corrected)},
            {"fused_keyframes_moved", tracking.refused_keyframes_moved},
            {"compact_keyframes_mib", tracking.refusion_store_mib},
            {"place_index_mib", t.place_index_mib}}},
          {"landmarks_created", t.landmarks_created},
          {"landmarks_culled", t.landmarks_culled},
          {"landmarks_found_moving", t.landmarks_found_moving},
          {"bundle_adjustments", t.bundle_adjustments},
          {"bundle_adjustment_observations_rejected", t.observations_rejected},
          {"depth_self_calibration", DepthCalibrationJson(t, options)},
          {"bundle_adjustment_thread", tracking.bundle_adjustment_thread},
          {"planar_motion", PlanarMotionJson(tracking, options)}};
}

}  // namespace

json TrackingJson(const TrackingFigures& tracking, const TrackerOptions& options) {
  const TrackerStatistics& t = tracking.statistics;
  json out = TrackerJson(tracking, options);
  if (tracking.prior) out["carried_by_given_poses"] = t.carried;
  if (const std::optional<DenseRefinementFigures>& dense = tracking.dense_refinement) {
    out["dense_refinement"] = {
        {"keyframes", dense->keyframes},         {"next_pairs", dense->next_pairs},
        {"next_taken", dense->next_taken},       {"revisit_pairs", dense->revisit_pairs},
        {"revisit_taken", dense->revisit_taken}, {"largest_move_m", dense->largest_move_m}};
  }
  const TrajectorySmoothingFigures& smoothing = tracking.smoothing;
  out["smoothing"] = {{"frames_moved", smoothing.frames_moved},
                      {"runs", smoothing.runs},
                      {"rms_move_m", smoothing.rms_move_m},
                      {"largest_move_m", smoothing.largest_move_m}};
  return out;
}

}  // namespace stillmap
