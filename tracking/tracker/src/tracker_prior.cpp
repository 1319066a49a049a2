// The tracker's prediction: constant velocity, and the motion of given poses (a robot's odometry,
// poses.use=prior) where that fails: no velocity yet, too few matches around the constant-velocity
// guess, or no pose from vision at all.
#include "stillmap/io/trajectory.h"
#include "tracker_impl.h"

namespace stillmap {

Eigen::Isometry3d Tracker::Impl::PriorPrediction() const {
  // The prior's motion from the last posed frame to this one, in the last camera's frame:
  // last_from_now = (world_from_last)^-1 * world_from_now, in the prior's own world.
  const Eigen::Isometry3d last_from_now = last_good_prior->inverse() * *next_prior;
  return last_from_now.inverse() * last_good_camera_from_world;
}

Eigen::Isometry3d Tracker::Impl::Predict(const Eigen::Isometry3d& last, double time) const {
  if (have_last && have_velocity) return velocity * last;
  if (HasPriorMotion()) return PriorPrediction();
  return MotionModelPose(time).value_or(last);
}

std::optional<Eigen::Isometry3d> Tracker::Impl::MotionModelPose(double time) const {
  // Lost since the last good pose: its velocity carried over the time since, for a short while.
  const double elapsed_s = time - last_good_time;
  if (!have_velocity || velocity_dt_s <= 0.0 ||
      elapsed_s > options.relocalization.motion_model_horizon_s) {
    return std::nullopt;
  }
  // The velocity's motion scaled from identity (slerp and a straight line, extrapolating).
  return InterpolatePose(Eigen::Isometry3d::Identity(), velocity, elapsed_s / velocity_dt_s) *
         last_good_camera_from_world;
}

void Tracker::Impl::SearchAroundPredictions(Eigen::Isometry3d* predicted, const LocalSet& local,
                                            const FrameData& frame, Association* association) {
  SearchByProjection(*predicted, local, options.matching.search_radius_px, frame, association);
  const int min_matches = options.matching.min_matches;
  if (association->count() < min_matches && HasPriorMotion()) {
    // The constant-velocity guess found little: the prior's, from scratch; the guess again when
    // the prior's finds no more.
    const int around_guess = association->count();
    const Eigen::Isometry3d prior = PriorPrediction();
    ClearMatches(*association);
    duplicates.clear();
    SearchByProjection(prior, local, options.matching.search_radius_px, frame, association);
    if (association->count() > around_guess) {
      *predicted = prior;
    } else {
      ClearMatches(*association);
      duplicates.clear();
      SearchByProjection(*predicted, local, options.matching.search_radius_px, frame, association);
    }
  }
  if (association->count() < min_matches) {
    SearchByProjection(*predicted, local, options.matching.wide_search_radius_px, frame,
                       association);
  }
}

}  // namespace stillmap
