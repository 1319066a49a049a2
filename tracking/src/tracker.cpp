#include "stillmap/tracking/tracker.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <climits>
#include <condition_variable>
#include <cstdint>
#include <cstring>
#include <deque>
#include <exception>
#include <map>
#include <mutex>
#include <thread>
#include <unordered_map>
#include <utility>

#include "stillmap/io/error.h"
#include "stillmap/tracking/matching.h"

namespace stillmap {

void TrackerOptions::Validate() const {
  features.Validate();
  auto require = [](bool ok, const char* message) {
    if (!ok) throw InputError(message);
  };
  require(search_radius_px > 0.0 && wide_search_radius_px >= search_radius_px &&
              refine_search_radius_px > 0.0,
          "tracking.search_radius must be positive and at most tracking.wide_search_radius");
  require(max_descriptor_distance > 0 && max_descriptor_distance <= 256,
          "tracking.max_descriptor_distance must lie in 1..256");
  require(match_ratio > 0.0f && match_ratio <= 1.0f, "tracking.match_ratio must lie in (0, 1]");
  require(min_matches >= 6, "tracking.min_matches must be at least 6");
  require(sigma_px > 0.0 && sigma_inverse_depth > 0.0,
          "tracking.sigma_px and tracking.sigma_inverse_depth must be positive");
  require(depth_calibration_interval > 0,
          "tracking.depth_calibration_interval must be a positive number of keyframes");
  require(depth_calibration.min_pairs > 0 && depth_calibration.max_residual_m > 0.0 &&
              depth_calibration.max_delta > 0.0 && depth_calibration.coefficient_sigma > 0.0 &&
              depth_calibration.residual_sigma_m > 0.0 &&
              depth_calibration.min_spread_reduction >= 0.0 &&
              depth_calibration.min_spread_reduction_m >= 0.0,
          "tracking.depth_calibration_* must be positive (the minimum reductions: not negative)");
  require(far_depth > 0.0 && far_depth_power >= 0.0,
          "tracking.far_depth must be positive and tracking.far_depth_power not negative");
  require(min_landmark_depth > 0.0 && max_landmark_depth > min_landmark_depth,
          "tracking.max_landmark_depth must exceed tracking.min_landmark_depth (> 0)");
  require(keyframe_ratio > 0.0 && keyframe_ratio <= 1.0,
          "tracking.keyframe_ratio must lie in (0, 1]");
  require(max_keyframe_interval >= 1 && min_keyframe_interval >= 1 &&
              min_keyframe_interval <= max_keyframe_interval,
          "tracking.min_keyframe_interval must lie in 1..tracking.max_keyframe_interval");
  require(local_window >= 2 && local_map_keyframes >= 1,
          "tracking.local_window must be at least 2 and tracking.local_map_keyframes at least 1");
  require(min_tracked >= 6 && min_relocalized >= min_tracked,
          "tracking.min_tracked must be at least 6 and at most tracking.min_relocalized");
  require(relocalization_keyframes >= 1, "tracking.relocalization_keyframes must be at least 1");
  require(new_map_after_lost >= 1, "tracking.new_map_after_lost must be at least 1");
  require(min_initial_points >= 20, "tracking.min_initial_points must be at least 20");
}

const char* TrackStatusName(TrackStatus status) {
  switch (status) {
    case TrackStatus::kInitialized:
      return "initialized";
    case TrackStatus::kTracked:
      return "tracked";
    case TrackStatus::kRelocalized:
      return "relocalized";
    case TrackStatus::kNewMap:
      return "new_map";
    case TrackStatus::kLost:
      return "lost";
  }
  return "unknown";
}

namespace {

using Clock = std::chrono::steady_clock;

double MillisecondsSince(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

// A 256-bit ORB descriptor as four words, so that the Hamming distance is four popcounts.
using Descriptor = std::array<uint64_t, 4>;

Descriptor DescriptorOf(const cv::Mat& descriptors, int row) {
  Descriptor out;
  std::memcpy(out.data(), descriptors.ptr<uint8_t>(row), sizeof(out));
  return out;
}

int HammingDistance(const Descriptor& a, const Descriptor& b) {
  return __builtin_popcountll(a[0] ^ b[0]) + __builtin_popcountll(a[1] ^ b[1]) +
         __builtin_popcountll(a[2] ^ b[2]) + __builtin_popcountll(a[3] ^ b[3]);
}

struct Landmark {
  Eigen::Vector3d position = Eigen::Vector3d::Zero();  // world frame
  Descriptor descriptor{};
  int octave = 0;
  int created_keyframe = 0;
  std::vector<std::pair<int, int>> observations;  // (keyframe id, feature index)
  int visible = 0;                                // frames in which it projected into the image
  int found = 0;                                  // frames in which it was an inlier
  size_t local_stamp = 0;                         // serial of the last local set it was put into
  size_t matched_stamp = 0;                       // frame serial when last matched
};

struct Keyframe {
  int id = 0;
  size_t frame_index = 0;
  double time = 0.0;
  Eigen::Isometry3d camera_from_world = Eigen::Isometry3d::Identity();
  FrameFeatures features;
  std::vector<Descriptor> descriptors;
  std::vector<int> landmark_of_feature;  // landmark id per feature, -1 none
  bool final = false;
};

// The current frame: features, descriptors and undistorted pixel positions, bucketed in a grid
// for radius searches.
class FrameData {
 public:
  FrameData(FrameFeatures features, const Camera& camera)
      : features_(std::move(features)), width_(camera.width), height_(camera.height) {
    const size_t n = features_.size();
    descriptors_.reserve(n);
    pixels_.reserve(n);
    columns_ = (width_ + 2 * kMargin) / kCell + 1;
    rows_ = (height_ + 2 * kMargin) / kCell + 1;
    cells_.assign(static_cast<size_t>(columns_) * static_cast<size_t>(rows_), {});
    for (size_t i = 0; i < n; ++i) {
      descriptors_.push_back(DescriptorOf(features_.descriptors, static_cast<int>(i)));
      const Eigen::Vector2d pixel(camera.fx * features_.normalized[i].x() + camera.cx,
                                  camera.fy * features_.normalized[i].y() + camera.cy);
      pixels_.push_back(pixel);
      cells_[static_cast<size_t>(CellIndex(Column(pixel.x()), Row(pixel.y())))].push_back(
          static_cast<int>(i));
    }
  }

  // Calls f(i) for every feature within `radius` of (u, v).
  template <typename F>
  void ForEachNear(double u, double v, double radius, F&& f) const {
    const int c0 = Column(u - radius), c1 = Column(u + radius);
    const int r0 = Row(v - radius), r1 = Row(v + radius);
    const double r2 = radius * radius;
    for (int r = r0; r <= r1; ++r) {
      for (int c = c0; c <= c1; ++c) {
        for (int i : cells_[static_cast<size_t>(CellIndex(c, r))]) {
          const Eigen::Vector2d& p = pixels_[static_cast<size_t>(i)];
          const double du = p.x() - u, dv = p.y() - v;
          if (du * du + dv * dv <= r2) f(i);
        }
      }
    }
  }

  const FrameFeatures& features() const { return features_; }
  FrameFeatures& features() { return features_; }
  const std::vector<Descriptor>& descriptors() const { return descriptors_; }
  std::vector<Descriptor>& descriptors() { return descriptors_; }
  size_t size() const { return features_.size(); }
  int octave(size_t i) const { return features_.keypoints[i].octave; }

 private:
  static constexpr int kCell = 20;    // px
  static constexpr int kMargin = 40;  // undistorted positions may fall slightly outside
  int Column(double u) const {
    return std::clamp(static_cast<int>((u + kMargin) / kCell), 0, columns_ - 1);
  }
  int Row(double v) const {
    return std::clamp(static_cast<int>((v + kMargin) / kCell), 0, rows_ - 1);
  }
  int CellIndex(int column, int row) const { return row * columns_ + column; }

  FrameFeatures features_;
  std::vector<Descriptor> descriptors_;
  std::vector<Eigen::Vector2d> pixels_;
  int width_, height_;
  int columns_ = 0, rows_ = 0;
  std::vector<std::vector<int>> cells_;
};

// A tracked frame, relative to its reference keyframe so that keyframe corrections carry over.
struct FrameRecord {
  double time = 0.0;
  int reference_keyframe = 0;
  Eigen::Isometry3d camera_from_reference = Eigen::Isometry3d::Identity();
};

// Feature -> landmark associations of the current frame.
struct Association {
  std::vector<int> landmark;  // per feature, -1 none
  std::vector<int> distance;  // Hamming distance of the association
  explicit Association(size_t n) : landmark(n, -1), distance(n, INT_MAX) {}
  int count() const {
    return static_cast<int>(
        std::count_if(landmark.begin(), landmark.end(), [](int id) { return id >= 0; }));
  }
};

using LocalSet = std::vector<std::pair<int, Landmark*>>;

}  // namespace

struct Tracker::Impl {
  Impl(const Camera& camera_in, const TrackerOptions& options_in)
      : camera(camera_in), options(options_in) {
    options.Validate();
    double scale = 1.0;
    for (int level = 0; level < options.features.pyramid_levels; ++level) {
      octave_scale.push_back(scale);
      scale *= options.features.scale_factor;
    }
    for (const double u : {0.0, 0.5, 1.0}) {
      for (const double v : {0.0, 0.5, 1.0}) {
        image_outline.emplace_back((u * (camera.width - 1) - camera.cx) / camera.fx,
                                   (v * (camera.height - 1) - camera.cy) / camera.fy);
      }
    }
    if (options.background_bundle_adjustment) worker = std::thread([this] { WorkerLoop(); });
  }

  ~Impl() {
    {
      const std::lock_guard<std::mutex> lock(mutex);
      stopping = true;
    }
    wake.notify_all();
    if (worker.joinable()) worker.join();
  }

  Impl(const Impl&) = delete;
  Impl& operator=(const Impl&) = delete;

  double OctaveScale(int octave) const {
    return octave_scale[static_cast<size_t>(
        std::clamp(octave, 0, static_cast<int>(octave_scale.size()) - 1))];
  }

  RgbdObservation Observation(const FrameFeatures& features, size_t i) const {
    RgbdObservation observation;
    observation.normalized = features.normalized[i];
    observation.depth_m = features.depth_m[i] * DepthFactor(features.normalized[i]);
    observation.sigma_normalized =
        options.sigma_px * OctaveScale(features.keypoints[i].octave) / camera.fx;
    observation.sigma_inverse_depth = options.sigma_inverse_depth;
    if (options.far_depth_power > 0.0 && observation.depth_m > options.far_depth) {
      observation.sigma_inverse_depth *=
          std::pow(observation.depth_m / options.far_depth, options.far_depth_power);
    }
    return observation;
  }

  double DepthFactor(const Eigen::Vector2d& normalized) const {
    return stats.depth_correction.Factor(normalized.x(), normalized.y());
  }

  // Refits the depth correction from every pair of consecutive observations with depth of the
  // local map's landmarks (raw depths, current keyframe poses).
  void CalibrateDepth() {
    const Clock::time_point start = Clock::now();
    std::vector<DepthPair> pairs;
    for (const auto& [id, landmark] : landmarks) {
      const auto& observations = landmark.observations;
      for (size_t k = 1; k < observations.size(); ++k) {
        const auto i = keyframes.find(observations[k - 1].first);
        const auto j = keyframes.find(observations[k].first);
        if (i == keyframes.end() || j == keyframes.end()) continue;
        const auto fi = static_cast<size_t>(observations[k - 1].second);
        const auto fj = static_cast<size_t>(observations[k].second);
        if (fi >= i->second.features.size() || fj >= j->second.features.size()) continue;
        const float zi = i->second.features.depth_m[fi], zj = j->second.features.depth_m[fj];
        if (!UsableDepth(zi) || !UsableDepth(zj)) continue;
        pairs.push_back({i->second.features.normalized[fi], j->second.features.normalized[fj], zi,
                         zj, j->second.camera_from_world * i->second.camera_from_world.inverse()});
      }
    }
    const DepthCorrectionFit fit =
        FitDepthCorrection(pairs, image_outline, options.depth_calibration);
    if (fit.ok) {
      stats.depth_correction = fit.correction;
      ++stats.depth_calibrations;
    } else if (fit.pairs_used >= options.depth_calibration.min_pairs) {
      ++stats.depth_calibrations_refused;
    }
    stats.last_depth_calibration = fit;
    stats.depth_calibration_ms += MillisecondsSince(start);
  }

  bool UsableDepth(float depth) const {
    return depth >= options.min_landmark_depth && depth <= options.max_landmark_depth;
  }

  // ---- Local map ------------------------------------------------------------------------------

  LocalSet CollectLocalLandmarks() {
    LocalSet local;
    const size_t stamp = ++collect_serial;
    const size_t count = map_keyframes.size();
    const size_t first = count > static_cast<size_t>(options.local_map_keyframes)
                             ? count - static_cast<size_t>(options.local_map_keyframes)
                             : 0;
    auto add = [&](int id) {
      if (id < 0) return;
      const auto it = landmarks.find(id);
      if (it == landmarks.end() || it->second.local_stamp == stamp) return;
      it->second.local_stamp = stamp;
      local.emplace_back(id, &it->second);
    };
    for (int id : last_frame_landmarks) add(id);
    for (size_t k = count; k-- > first;) {
      for (int id : keyframes.at(map_keyframes[k]).landmark_of_feature) add(id);
    }
    return local;
  }

  // Projects the local landmarks not matched yet with camera_from_world and matches each to the
  // closest descriptor within radius_px (scaled by the landmark's octave). A feature keeps the
  // landmark with the smallest distance.
  void SearchByProjection(const Eigen::Isometry3d& camera_from_world, const LocalSet& local,
                          double radius_px, const FrameData& frame, Association* association) {
    const Eigen::Matrix3d rotation = camera_from_world.linear();
    const Eigen::Vector3d translation = camera_from_world.translation();
    for (const auto& entry : local) {
      const int id = entry.first;
      Landmark* const landmark = entry.second;
      if (landmark->matched_stamp == frame_serial) continue;
      const Eigen::Vector3d p = rotation * landmark->position + translation;
      if (p.z() < options.min_landmark_depth) continue;
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
      if (best_index < 0 || best > options.max_descriptor_distance) continue;
      // The ratio test only between candidates of one pyramid level: the same corner is often
      // detected at two levels with nearly the same descriptor (ORB-SLAM2 does the same).
      if (second_octave == best_octave && second != INT_MAX &&
          static_cast<float>(best) > options.match_ratio * static_cast<float>(second)) {
        continue;
      }
      const size_t feature = static_cast<size_t>(best_index);
      if (best >= association->distance[feature]) continue;
      if (association->landmark[feature] >= 0) {
        landmarks.at(association->landmark[feature]).matched_stamp = 0;  // displaced
      }
      association->landmark[feature] = id;
      association->distance[feature] = best;
      landmark->matched_stamp = frame_serial;
    }
  }

  struct PoseEstimate {
    bool ok = false;
    Eigen::Isometry3d camera_from_world = Eigen::Isometry3d::Identity();
    int matches = 0;
    int inliers = 0;
    double rmse_px = 0.0;
  };

  // The associated features and their landmarks' positions.
  void GatherAssociations(const Association& association, std::vector<size_t>* features,
                          std::vector<Eigen::Vector3d>* points) const {
    for (size_t i = 0; i < association.landmark.size(); ++i) {
      if (association.landmark[i] < 0) continue;
      features->push_back(i);
      points->push_back(landmarks.at(association.landmark[i]).position);
    }
  }

  // Motion-only refinement over the associations; drops the outliers from `association`.
  PoseEstimate Refine(const Eigen::Isometry3d& initial, const FrameData& frame,
                      Association* association, const RefinementOptions& refinement) {
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
    estimate.ok = refined.ok() && static_cast<int>(refined.inliers.size()) >= options.min_tracked;
    estimate.camera_from_world = refined.camera_from_world;
    estimate.inliers = static_cast<int>(refined.inliers.size());
    estimate.rmse_px = refined.reprojection_rmse * camera.fx;
    return estimate;
  }

  // PnP-RANSAC on the associations (falling back to `guess` when allowed), a short refinement, a
  // second projection search around that pose for landmarks not matched yet, and the full
  // refinement over all associations.
  PoseEstimate EstimatePose(const Eigen::Isometry3d& guess, bool guess_usable,
                            const LocalSet& local, const FrameData& frame,
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
    SearchByProjection(first.camera_from_world, local, options.refine_search_radius_px, frame,
                       association);
    PoseEstimate estimate = Refine(first.camera_from_world, frame, association, options.refinement);
    estimate.matches = std::max(estimate.matches, failed.matches);
    return estimate;
  }

  void Unmatch(size_t feature, Association* association) {
    const int id = association->landmark[feature];
    if (id < 0) return;
    landmarks.at(id).matched_stamp = 0;
    association->landmark[feature] = -1;
    association->distance[feature] = INT_MAX;
  }

  // Descriptor matching against the landmarks of recent keyframes, newest first.
  PoseEstimate Relocalize(const FrameData& frame, Association* association) {
    const size_t count = map_keyframes.size();
    const size_t tries = std::min(count, static_cast<size_t>(options.relocalization_keyframes));
    MatchOptions match_options;
    for (size_t t = 0; t < tries; ++t) {
      const Keyframe& keyframe = keyframes.at(map_keyframes[count - 1 - t]);
      cv::Mat train;
      std::vector<int> landmark_of_row;
      for (size_t i = 0; i < keyframe.features.size(); ++i) {
        const int id = keyframe.landmark_of_feature[i];
        if (id < 0 || landmarks.count(id) == 0) continue;
        train.push_back(keyframe.features.descriptors.row(static_cast<int>(i)));
        landmark_of_row.push_back(id);
      }
      if (static_cast<int>(landmark_of_row.size()) < options.min_relocalized) continue;
      *association = Association(frame.size());
      for (const cv::DMatch& match :
           MatchDescriptors(frame.features().descriptors, train, match_options)) {
        const int id = landmark_of_row[static_cast<size_t>(match.trainIdx)];
        Landmark& landmark = landmarks.at(id);
        if (landmark.matched_stamp == frame_serial) continue;
        landmark.matched_stamp = frame_serial;
        association->landmark[static_cast<size_t>(match.queryIdx)] = id;
        association->distance[static_cast<size_t>(match.queryIdx)] =
            static_cast<int>(match.distance);
      }
      if (association->count() < options.min_relocalized) {
        ClearMatches(*association);
        continue;
      }
      const LocalSet local = CollectLocalLandmarks();
      PoseEstimate estimate =
          EstimatePose(keyframe.camera_from_world, false, local, frame, association);
      if (estimate.ok && estimate.inliers >= options.min_relocalized) return estimate;
      ClearMatches(*association);
    }
    *association = Association(frame.size());
    return {};
  }

  void ClearMatches(Association& association) {
    for (size_t i = 0; i < association.landmark.size(); ++i) Unmatch(i, &association);
  }

  // ---- Keyframes ------------------------------------------------------------------------------

  bool NeedKeyframe(const FrameData& frame, const Association& association, int inliers) const {
    if (inliers <= 15) return false;
    if (frames_since_keyframe >= options.max_keyframe_interval) return true;
    // Weak tracking asks for a keyframe at once; otherwise not within min_keyframe_interval.
    const bool weak = inliers < options.weak_tracking_inliers;
    if (!weak && frames_since_keyframe < options.min_keyframe_interval) return false;
    if (weak) return true;
    const Keyframe& reference = keyframes.at(map_keyframes.back());
    const size_t min_observations = map_keyframes.size() <= 2 ? 1 : 2;
    int reference_tracked = 0;
    for (int id : reference.landmark_of_feature) {
      if (id < 0) continue;
      const auto it = landmarks.find(id);
      if (it != landmarks.end() && it->second.observations.size() >= min_observations) {
        ++reference_tracked;
      }
    }
    int tracked_close = 0, untracked_close = 0;
    for (size_t i = 0; i < frame.size(); ++i) {
      const float depth = frame.features().depth_m[i];
      if (depth <= 0.0f || depth > options.close_depth) continue;
      (association.landmark[i] >= 0 ? tracked_close : untracked_close) += 1;
    }
    const bool need_close = tracked_close < 100 && untracked_close > 70;
    return inliers < options.keyframe_ratio * reference_tracked || need_close;
  }

  int InsertKeyframe(const Eigen::Isometry3d& camera_from_world, FrameData& frame,
                     const Association& association, size_t frame_index, double time,
                     std::unique_lock<std::mutex>& lock) {
    Keyframe keyframe;
    keyframe.id = next_keyframe++;
    keyframe.frame_index = frame_index;
    keyframe.time = time;
    keyframe.camera_from_world = camera_from_world;
    keyframe.landmark_of_feature.assign(frame.size(), -1);
    const Eigen::Isometry3d world_from_camera = camera_from_world.inverse();
    for (size_t i = 0; i < frame.size(); ++i) {
      const int matched = association.landmark[i];
      if (matched >= 0) {
        keyframe.landmark_of_feature[i] = matched;
        landmarks.at(matched).observations.emplace_back(keyframe.id, static_cast<int>(i));
        continue;
      }
      if (!UsableDepth(frame.features().depth_m[i])) continue;
      const int id = next_landmark++;
      Landmark& landmark = landmarks[id];
      landmark.position = world_from_camera * (frame.features().PointInCamera(i) *
                                               DepthFactor(frame.features().normalized[i]));
      landmark.descriptor = frame.descriptors()[i];
      landmark.octave = frame.octave(i);
      landmark.created_keyframe = keyframe.id;
      landmark.observations.emplace_back(keyframe.id, static_cast<int>(i));
      landmark.visible = 1;
      landmark.found = 1;
      keyframe.landmark_of_feature[i] = id;
      recent_landmarks.push_back(id);
      ++stats.landmarks_created;
    }
    keyframe.features = std::move(frame.features());
    keyframe.descriptors = std::move(frame.descriptors());
    const int id = keyframe.id;
    keyframes.emplace(id, std::move(keyframe));
    map_keyframes.push_back(id);
    ++stats.keyframes;
    frames_since_keyframe = 0;
    CullRecentLandmarks(id);
    if (options.depth_self_calibration && options.depth_calibration_interval > 0 &&
        map_keyframes.size() % static_cast<size_t>(options.depth_calibration_interval) == 0) {
      CalibrateDepth();
    }
    if (map_keyframes.size() >= 2) {
      if (options.background_bundle_adjustment) {
        ba_requested = true;
        wake.notify_one();
      } else {
        RunBundleAdjustment(lock);
      }
    }
    UpdateFinal();
    return id;
  }

  // ORB-SLAM2's culling of recent map points: found in under a quarter of the frames where they
  // were visible, or seen by a single keyframe two keyframes after their creation.
  void CullRecentLandmarks(int current_keyframe) {
    std::deque<int> kept;
    for (int id : recent_landmarks) {
      const auto it = landmarks.find(id);
      if (it == landmarks.end()) continue;
      const Landmark& landmark = it->second;
      const int age = current_keyframe - landmark.created_keyframe;
      const bool rarely_found = landmark.visible >= 4 && 4 * landmark.found < landmark.visible;
      const bool seen_once = age >= 2 && landmark.observations.size() < 2;
      if (rarely_found || seen_once) {
        EraseLandmark(id);
      } else if (age < 3) {
        kept.push_back(id);
      }
    }
    recent_landmarks = std::move(kept);
  }

  void EraseLandmark(int id) {
    const auto it = landmarks.find(id);
    if (it == landmarks.end()) return;
    for (const auto& [keyframe_id, feature] : it->second.observations) {
      const auto keyframe = keyframes.find(keyframe_id);
      if (keyframe == keyframes.end()) continue;
      int& slot = keyframe->second.landmark_of_feature[static_cast<size_t>(feature)];
      if (slot == id) slot = -1;
    }
    landmarks.erase(it);
    ++stats.landmarks_culled;
  }

  // Keyframes older than both the current window and the window of a running adjustment are
  // final.
  void UpdateFinal(bool all = false) {
    const size_t count = map_keyframes.size();
    const size_t window_first = count > static_cast<size_t>(options.local_window)
                                    ? count - static_cast<size_t>(options.local_window)
                                    : 0;
    int boundary = all ? INT_MAX : (count > 0 ? map_keyframes[window_first] : INT_MAX);
    boundary = std::min(boundary, all ? INT_MAX : running_window_first);
    while (next_final < count && map_keyframes[next_final] < boundary) {
      Keyframe& keyframe = keyframes.at(map_keyframes[next_final]);
      if (!keyframe.final) {
        keyframe.final = true;
        FinalKeyframe done{keyframe.id,
                           keyframe.frame_index,
                           keyframe.time,
                           keyframe.camera_from_world.inverse(),
                           {}};
        for (int id : keyframe.landmark_of_feature) {
          if (id >= 0) done.landmarks.push_back(id);
        }
        final_queue.push_back(std::move(done));
      }
      ++next_final;
    }
  }

  // A new local map whose first keyframe is this frame at camera_from_world.
  void StartMap(const Eigen::Isometry3d& camera_from_world, FrameData& frame, size_t frame_index,
                double time, std::unique_lock<std::mutex>& lock) {
    ba_done.wait(lock, [this] { return !ba_requested && !ba_running; });
    UpdateFinal(true);
    for (int id : map_keyframes) {  // the old map's features are no longer needed
      Keyframe& keyframe = keyframes.at(id);
      keyframe.features = FrameFeatures();
      keyframe.descriptors.clear();
      keyframe.landmark_of_feature.clear();
    }
    landmarks.clear();
    recent_landmarks.clear();
    last_frame_landmarks.clear();
    map_keyframes.clear();
    next_final = 0;
    const Association none(frame.size());
    InsertKeyframe(camera_from_world, frame, none, frame_index, time, lock);
    have_map = true;
  }

  // ---- Local bundle adjustment ----------------------------------------------------------------

  void WorkerLoop() {
    std::unique_lock<std::mutex> lock(mutex);
    while (true) {
      wake.wait(lock, [this] { return ba_requested || stopping; });
      if (stopping) break;
      ba_requested = false;
      ba_running = true;
      try {
        RunBundleAdjustment(lock);
      } catch (...) {
        worker_error = std::current_exception();
      }
      ba_running = false;
      UpdateFinal();
      ba_done.notify_all();
    }
    ba_running = false;
    ba_done.notify_all();
  }

  // Called with the lock held; releases it while Ceres solves.
  void RunBundleAdjustment(std::unique_lock<std::mutex>& lock) {
    const size_t count = map_keyframes.size();
    if (count < 2) return;
    const size_t window_first = count > static_cast<size_t>(options.local_window)
                                    ? count - static_cast<size_t>(options.local_window)
                                    : 0;
    BundleAdjustmentProblem problem;
    std::vector<int> keyframe_ids, landmark_ids;
    std::unordered_map<int, int> keyframe_index, landmark_index;
    struct ObservationRef {
      int keyframe_id, feature, landmark_id;
    };
    std::vector<ObservationRef> refs;
    for (size_t k = window_first; k < count; ++k) {
      const int id = map_keyframes[k];
      keyframe_index[id] = static_cast<int>(problem.keyframes.size());
      keyframe_ids.push_back(id);
      problem.keyframes.push_back({keyframes.at(id).camera_from_world, false});
    }
    for (size_t k = window_first; k < count; ++k) {
      for (int id : keyframes.at(map_keyframes[k]).landmark_of_feature) {
        if (id < 0 || landmark_index.count(id) > 0) continue;
        landmark_index[id] = static_cast<int>(problem.landmarks.size());
        landmark_ids.push_back(id);
        problem.landmarks.push_back(landmarks.at(id).position);
      }
    }
    bool any_fixed = false;
    for (size_t l = 0; l < landmark_ids.size(); ++l) {
      for (const auto& [keyframe_id, feature] : landmarks.at(landmark_ids[l]).observations) {
        auto it = keyframe_index.find(keyframe_id);
        if (it == keyframe_index.end()) {
          it =
              keyframe_index.emplace(keyframe_id, static_cast<int>(problem.keyframes.size())).first;
          keyframe_ids.push_back(keyframe_id);
          problem.keyframes.push_back({keyframes.at(keyframe_id).camera_from_world, true});
          any_fixed = true;
        }
        const Keyframe& keyframe = keyframes.at(keyframe_id);
        problem.observations.push_back(
            {it->second, static_cast<int>(l),
             Observation(keyframe.features, static_cast<size_t>(feature))});
        refs.push_back({keyframe_id, feature, landmark_ids[l]});
      }
    }
    if (!any_fixed) problem.keyframes[0].fixed = true;  // the gauge
    running_window_first = map_keyframes[window_first];

    lock.unlock();
    const Clock::time_point start = Clock::now();
    BundleAdjustmentResult result;
    try {
      result = SolveBundleAdjustment(problem, options.bundle_adjustment);
    } catch (...) {
      lock.lock();
      running_window_first = INT_MAX;
      throw;
    }
    const double elapsed_ms = MillisecondsSince(start);
    lock.lock();
    running_window_first = INT_MAX;

    // Write back what still exists (tracking may have culled landmarks meanwhile).
    for (size_t k = 0; k < keyframe_ids.size(); ++k) {
      if (problem.keyframes[k].fixed) continue;
      const auto it = keyframes.find(keyframe_ids[k]);
      if (it != keyframes.end()) it->second.camera_from_world = result.camera_from_world[k];
    }
    for (size_t l = 0; l < landmark_ids.size(); ++l) {
      const auto it = landmarks.find(landmark_ids[l]);
      if (it != landmarks.end()) it->second.position = result.landmarks[l];
    }
    for (size_t o = 0; o < refs.size(); ++o) {
      if (!result.outlier[o]) continue;
      const ObservationRef& ref = refs[o];
      const auto landmark = landmarks.find(ref.landmark_id);
      if (landmark == landmarks.end()) continue;
      auto& observations = landmark->second.observations;
      observations.erase(std::remove(observations.begin(), observations.end(),
                                     std::make_pair(ref.keyframe_id, ref.feature)),
                         observations.end());
      const auto keyframe = keyframes.find(ref.keyframe_id);
      if (keyframe != keyframes.end()) {
        int& slot = keyframe->second.landmark_of_feature[static_cast<size_t>(ref.feature)];
        if (slot == ref.landmark_id) slot = -1;
      }
      ++stats.observations_rejected;
      if (observations.empty()) EraseLandmark(ref.landmark_id);
    }
    ++stats.bundle_adjustments;
    stats.bundle_adjustment_ms += elapsed_ms;
  }

  void RethrowWorkerError() {
    if (worker_error) {
      std::exception_ptr error = worker_error;
      worker_error = nullptr;
      std::rethrow_exception(error);
    }
  }

  // ---- Per frame --------------------------------------------------------------------------------

  TrackResult Track(size_t frame_index, double time, const cv::Mat& gray, const cv::Mat& depth_m,
                    const cv::Mat& ignore_mask) {
    const Clock::time_point start = Clock::now();
    TrackResult result;
    FrameData frame(ExtractFeatures(gray, depth_m, camera, ignore_mask, options.features), camera);
    result.features = static_cast<int>(frame.size());
    result.timings.extract_ms = MillisecondsSince(start);

    std::unique_lock<std::mutex> lock(mutex);
    RethrowWorkerError();
    ++frame_serial;
    ++stats.frames;
    int with_depth = 0;
    for (float depth : frame.features().depth_m) with_depth += UsableDepth(depth) ? 1 : 0;

    if (!have_map) {
      if (with_depth >= options.min_initial_points) {
        const Eigen::Isometry3d pose =
            have_good ? last_good_camera_from_world : Eigen::Isometry3d::Identity();
        StartMap(pose, frame, frame_index, time, lock);
        result.status = TrackStatus::kInitialized;
        result.keyframe_id = map_keyframes.back();
        Accept(pose, time, {}, &result);
      } else {
        ++stats.lost;
      }
      result.timings.total_ms = MillisecondsSince(start);
      return result;
    }

    // Constant-velocity prediction, then projection search (a wider one when it finds little).
    Clock::time_point stage = Clock::now();
    const Eigen::Isometry3d last = have_last ? last_camera_from_world : last_good_camera_from_world;
    const Eigen::Isometry3d predicted = have_velocity ? velocity * last : last;
    const LocalSet local = CollectLocalLandmarks();
    Association association(frame.size());
    SearchByProjection(predicted, local, options.search_radius_px, frame, &association);
    if (association.count() < options.min_matches) {
      SearchByProjection(predicted, local, options.wide_search_radius_px, frame, &association);
    }
    result.timings.match_ms = MillisecondsSince(stage);

    stage = Clock::now();
    PoseEstimate estimate;
    if (association.count() >= options.min_matches) {
      estimate = EstimatePose(predicted, true, local, frame, &association);
    }
    const bool was_lost = consecutive_lost > 0;
    if (!estimate.ok) {
      ClearMatches(association);
      estimate = Relocalize(frame, &association);
    }
    result.timings.pose_ms = MillisecondsSince(stage);
    result.matches = estimate.matches;

    stage = Clock::now();
    if (estimate.ok) {
      result.status = was_lost ? TrackStatus::kRelocalized : TrackStatus::kTracked;
      if (was_lost) ++stats.relocalized;
      result.inliers = estimate.inliers;
      result.reprojection_rmse_px = estimate.rmse_px;
      CountVisibility(estimate.camera_from_world, local, association);
      ++frames_since_keyframe;
      if (NeedKeyframe(frame, association, estimate.inliers)) {
        result.keyframe_id =
            InsertKeyframe(estimate.camera_from_world, frame, association, frame_index, time, lock);
      }
      Accept(estimate.camera_from_world, time, association.landmark, &result);
    } else {
      ++consecutive_lost;
      ++stats.lost;
      have_last = false;
      have_velocity = false;
      if (consecutive_lost >= options.new_map_after_lost &&
          with_depth >= options.min_initial_points) {
        StartMap(last_good_camera_from_world, frame, frame_index, time, lock);
        ++stats.new_maps;
        --stats.lost;
        result.status = TrackStatus::kNewMap;
        result.keyframe_id = map_keyframes.back();
        Accept(last_good_camera_from_world, time, {}, &result);
      }
    }
    result.timings.keyframe_ms = MillisecondsSince(stage);
    result.timings.total_ms = MillisecondsSince(start);
    return result;
  }

  // Visible / found counts for landmark culling.
  void CountVisibility(const Eigen::Isometry3d& camera_from_world, const LocalSet& local,
                       const Association& association) {
    for (const auto& [id, landmark] : local) {
      const Eigen::Vector3d p = camera_from_world * landmark->position;
      if (p.z() < options.min_landmark_depth) continue;
      const double u = camera.fx * p.x() / p.z() + camera.cx;
      const double v = camera.fy * p.y() / p.z() + camera.cy;
      if (u >= 0.0 && v >= 0.0 && u < camera.width && v < camera.height) ++landmark->visible;
    }
    for (int id : association.landmark) {
      if (id >= 0) ++landmarks.at(id).found;
    }
  }

  // Bookkeeping for a frame with a pose.
  void Accept(const Eigen::Isometry3d& camera_from_world, double time,
              const std::vector<int>& matched, TrackResult* result) {
    if (have_last) velocity = camera_from_world * last_camera_from_world.inverse();
    have_velocity = have_last;
    have_last = true;
    last_camera_from_world = camera_from_world;
    have_good = true;
    last_good_camera_from_world = camera_from_world;
    consecutive_lost = 0;
    last_frame_landmarks.clear();
    for (int id : matched) {
      if (id >= 0) last_frame_landmarks.push_back(id);
    }
    const Keyframe& reference = keyframes.at(map_keyframes.back());
    records.push_back(
        {time, reference.id, camera_from_world * reference.camera_from_world.inverse()});
    ++stats.tracked;
    result->world_from_camera = camera_from_world.inverse();
  }

  Camera camera;
  TrackerOptions options;
  std::vector<double> octave_scale;

  mutable std::mutex mutex;  // guards everything below
  std::unordered_map<int, Landmark> landmarks;
  std::map<int, Keyframe> keyframes;
  std::vector<int> map_keyframes;  // the current local map's keyframes, oldest first
  std::deque<int> recent_landmarks;
  int next_landmark = 0;
  int next_keyframe = 0;
  bool have_map = false;
  size_t next_final = 0;  // position in map_keyframes of the first keyframe not final yet
  std::vector<FinalKeyframe> final_queue;

  size_t frame_serial = 0;
  size_t collect_serial = 0;
  bool have_last = false;
  Eigen::Isometry3d last_camera_from_world = Eigen::Isometry3d::Identity();
  bool have_velocity = false;
  Eigen::Isometry3d velocity = Eigen::Isometry3d::Identity();
  bool have_good = false;
  Eigen::Isometry3d last_good_camera_from_world = Eigen::Isometry3d::Identity();
  int consecutive_lost = 0;
  int frames_since_keyframe = 0;
  std::vector<int> last_frame_landmarks;
  std::vector<FrameRecord> records;
  TrackerStatistics stats;
  // Normalized coordinates of the image's corners, edge midpoints and centre: where the depth
  // correction is bounded.
  std::vector<Eigen::Vector2d> image_outline;

  std::thread worker;
  std::condition_variable wake;     // the worker waits for a request
  std::condition_variable ba_done;  // StartMap and Finish wait for the worker
  bool ba_requested = false;
  bool ba_running = false;
  bool stopping = false;
  int running_window_first = INT_MAX;  // first keyframe id of the running adjustment's window
  std::exception_ptr worker_error;
};

Tracker::Tracker(const Camera& camera, const TrackerOptions& options)
    : impl_(std::make_unique<Impl>(camera, options)) {}

Tracker::~Tracker() = default;

TrackResult Tracker::Track(size_t frame_index, double time, const cv::Mat& gray,
                           const cv::Mat& depth_m, const cv::Mat& ignore_mask) {
  return impl_->Track(frame_index, time, gray, depth_m, ignore_mask);
}

std::optional<Eigen::Isometry3d> Tracker::PredictedPose() const {
  const std::lock_guard<std::mutex> lock(impl_->mutex);
  if (!impl_->have_map || !impl_->have_last) return std::nullopt;
  const Eigen::Isometry3d predicted = impl_->have_velocity
                                          ? impl_->velocity * impl_->last_camera_from_world
                                          : impl_->last_camera_from_world;
  return predicted.inverse();
}

std::vector<FinalKeyframe> Tracker::TakeFinalKeyframes() {
  const std::lock_guard<std::mutex> lock(impl_->mutex);
  impl_->RethrowWorkerError();
  std::vector<FinalKeyframe> out;
  out.swap(impl_->final_queue);
  return out;
}

void Tracker::Finish() {
  std::unique_lock<std::mutex> lock(impl_->mutex);
  impl_->ba_done.wait(lock, [this] { return !impl_->ba_requested && !impl_->ba_running; });
  impl_->RethrowWorkerError();
  if (impl_->map_keyframes.size() >= 2) impl_->RunBundleAdjustment(lock);
  impl_->UpdateFinal(true);
}

Trajectory Tracker::TrackedTrajectory() const {
  const std::lock_guard<std::mutex> lock(impl_->mutex);
  std::vector<StampedPose> poses;
  poses.reserve(impl_->records.size());
  for (const FrameRecord& record : impl_->records) {
    const Keyframe& reference = impl_->keyframes.at(record.reference_keyframe);
    poses.push_back(
        {record.time, (record.camera_from_reference * reference.camera_from_world).inverse()});
  }
  return Trajectory(std::move(poses));
}

TrackerStatistics Tracker::statistics() const {
  const std::lock_guard<std::mutex> lock(impl_->mutex);
  TrackerStatistics stats = impl_->stats;
  stats.landmarks = impl_->landmarks.size();
  return stats;
}

}  // namespace stillmap
