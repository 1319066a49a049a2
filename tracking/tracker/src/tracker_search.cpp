#include "stillmap/tracking/matching.h"
#include "tracker_impl.h"

namespace stillmap {

void Tracker::Impl::SearchByProjection(const Eigen::Isometry3d& camera_from_world,
                                       const LocalSet& local, double radius_px,
                                       const FrameData& frame, Association* association) {
  const Eigen::Matrix3d rotation = camera_from_world.linear();
  const Eigen::Vector3d translation = camera_from_world.translation();
  for (const auto& entry : local) {
    const int id = entry.first;
    Landmark* const landmark = entry.second;
    if (landmark->matched_stamp == match_serial) continue;
    const Eigen::Vector3d p = rotation * landmark->position + translation;
    if (p.z() < options.matching.min_landmark_depth) continue;
    const double u = camera.fx * p.x() / p.z() + camera.cx;
    const double v = camera.fy * p.y() / p.z() + camera.cy;
    if (u < 0.0 || v < 0.0 || u >= camera.width || v >= camera.height) continue;
    const double radius = radius_px * OctaveScale(landmark->octave);
    int best = INT_MAX, second = INT_MAX, best_index = -1, best_octave = -1, second_octave = -1;
    frame.ForEachNear(u, v, radius, [&](int i) {
      const int distance =
          HammingDistance(landmark->descriptor, frame.descriptors()[static_cast<size_t>(i)]);
      const int octave = frame.octave(static_cast<size_t>(i));
      if (distance < best) {
        second = best;
        second_octave = best_octave;
        best = distance;
        best_index = i;
        best_octave = octave;
      } else if (distance < second) {
        second = distance;
        second_octave = octave;
      }
    });
    if (best_index < 0 || best > options.matching.max_descriptor_distance) continue;
    // The ratio test only between candidates of one pyramid level: the same corner is often
    // detected at two levels with nearly the same descriptor (ORB-SLAM2 does the same).
    if (second_octave == best_octave && second != INT_MAX &&
        static_cast<float>(best) > options.matching.match_ratio * static_cast<float>(second)) {
      continue;
    }
    const size_t feature = static_cast<size_t>(best_index);
    if (best >= association->distance[feature]) {
      if (association->landmark[feature] >= 0) duplicates.push_back({feature, id, best});
      continue;
    }
    if (association->landmark[feature] >= 0) {
      duplicates.push_back(
          {feature, association->landmark[feature], association->distance[feature]});
      landmarks.at(association->landmark[feature]).matched_stamp = 0;  // displaced
    }
    association->landmark[feature] = id;
    association->distance[feature] = best;
    landmark->matched_stamp = match_serial;
  }
}

void Tracker::Impl::GatherAssociations(const Association& association,
                                       std::vector<size_t>* features,
                                       std::vector<Eigen::Vector3d>* points) const {
  for (size_t i = 0; i < association.landmark.size(); ++i) {
    if (association.landmark[i] < 0) continue;
    features->push_back(i);
    points->push_back(landmarks.at(association.landmark[i]).position);
  }
}

Tracker::Impl::PoseEstimate Tracker::Impl::Refine(const Eigen::Isometry3d& initial,
                                                  const FrameData& frame, Association* association,
                                                  const RefinementOptions& refinement) {
  std::vector<size_t> feature_of;
  std::vector<Eigen::Vector3d> points;
  GatherAssociations(*association, &feature_of, &points);
  std::vector<RgbdObservation> observations;
  observations.reserve(feature_of.size());
  for (size_t i : feature_of) observations.push_back(Observation(frame.features(), i));
  PoseEstimate estimate;
  estimate.matches = static_cast<int>(points.size());
  const PoseResult refined = RefinePose(initial, points, observations, refinement);
  std::vector<bool> inlier(points.size(), false);
  for (int k : refined.inliers) inlier[static_cast<size_t>(k)] = true;
  for (size_t k = 0; k < points.size(); ++k) {
    if (!inlier[k]) Unmatch(feature_of[k], association);
  }
  estimate.ok = refined.ok() &&
                static_cast<int>(refined.inliers.size()) >= options.relocalization.min_tracked;
  estimate.camera_from_world = refined.camera_from_world;
  estimate.inliers = static_cast<int>(refined.inliers.size());
  estimate.rmse_px = refined.reprojection_rmse * camera.fx;
  return estimate;
}

Tracker::Impl::PoseEstimate Tracker::Impl::EstimatePose(const Eigen::Isometry3d& guess,
                                                        bool guess_usable, const LocalSet& local,
                                                        const FrameData& frame,
                                                        Association* association) {
  std::vector<size_t> feature_of;
  std::vector<Eigen::Vector3d> points;
  GatherAssociations(*association, &feature_of, &points);
  std::vector<Eigen::Vector2d> normalized;
  normalized.reserve(feature_of.size());
  for (size_t i : feature_of) normalized.push_back(frame.features().normalized[i]);
  PoseEstimate failed;
  failed.matches = static_cast<int>(points.size());
  const PoseResult pnp = EstimatePosePnp(points, normalized, options.pnp);
  if (!pnp.ok() && !guess_usable) return failed;
  RefinementOptions quick = options.refinement;
  quick.rounds = 2;  // a first pose for the second search; the last refinement does all rounds
  const PoseEstimate first =
      Refine(pnp.ok() ? pnp.camera_from_world : guess, frame, association, quick);
  if (!first.ok) return failed;
  SearchByProjection(first.camera_from_world, local, options.matching.refine_search_radius_px,
                     frame, association);
  PoseEstimate estimate = Refine(first.camera_from_world, frame, association, options.refinement);
  estimate.matches = std::max(estimate.matches, failed.matches);
  return estimate;
}

void Tracker::Impl::Unmatch(size_t feature, Association* association) {
  const int id = association->landmark[feature];
  if (id < 0) return;
  landmarks.at(id).matched_stamp = 0;
  association->landmark[feature] = -1;
  association->distance[feature] = INT_MAX;
}

Tracker::Impl::PoseEstimate Tracker::Impl::Relocalize(const FrameData& frame,
                                                      Association* association) {
  // The place index's best candidates first (the camera may be back at an earlier place), then
  // the most recent keyframes.
  std::vector<int> tries = loops.RelocalizationCandidates(frame.features().descriptors);
  const size_t count = map_keyframes.size();
  for (size_t t = 0;
       t < std::min(count, static_cast<size_t>(options.relocalization.relocalization_keyframes));
       ++t) {
    const int id = map_keyframes[count - 1 - t];
    if (std::find(tries.begin(), tries.end(), id) == tries.end()) tries.push_back(id);
  }
  for (const int id : tries) {
    PoseEstimate estimate =
        VerifyPlace(frame, id, options.relocalization.min_relocalized, association);
    if (estimate.ok) return estimate;
  }
  *association = Association(frame.size());
  return {};
}

Tracker::Impl::PoseEstimate Tracker::Impl::VerifyPlace(const FrameData& frame, int keyframe_id,
                                                       int min_inliers, Association* association) {
  const Keyframe& keyframe = keyframes.at(keyframe_id);
  cv::Mat train;
  std::vector<int> landmark_of_row;
  for (size_t i = 0; i < keyframe.landmark_of_feature.size(); ++i) {
    const int id = keyframe.landmark_of_feature[i];
    if (id < 0 || landmarks.count(id) == 0) continue;
    train.push_back(keyframe.features.descriptors.row(static_cast<int>(i)));
    landmark_of_row.push_back(id);
  }
  *association = Association(frame.size());
  if (static_cast<int>(landmark_of_row.size()) < min_inliers) return {};
  for (const cv::DMatch& match :
       MatchDescriptors(frame.features().descriptors, train, MatchOptions{})) {
    const int id = landmark_of_row[static_cast<size_t>(match.trainIdx)];
    Landmark& landmark = landmarks.at(id);
    if (landmark.matched_stamp == match_serial) continue;
    landmark.matched_stamp = match_serial;
    association->landmark[static_cast<size_t>(match.queryIdx)] = id;
    association->distance[static_cast<size_t>(match.queryIdx)] = static_cast<int>(match.distance);
  }
  if (association->count() < min_inliers) {
    ClearMatches(*association);
    return {};
  }
  const LocalSet local = PlaceLandmarks(keyframe_id);
  PoseEstimate estimate =
      EstimatePose(keyframe.camera_from_world, false, local, frame, association);
  if (estimate.ok && estimate.inliers >= min_inliers) return estimate;
  ClearMatches(*association);
  return {};
}

void Tracker::Impl::ClearMatches(Association& association) {
  for (size_t i = 0; i < association.landmark.size(); ++i) Unmatch(i, &association);
}

void Tracker::Impl::RestoreMatches(const Association& earlier, Association* association) {
  ClearMatches(*association);
  *association = earlier;
  for (const int id : association->landmark) {
    if (id >= 0) landmarks.at(id).matched_stamp = match_serial;
  }
}

}  // namespace stillmap
