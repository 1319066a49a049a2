// Internal to the tracker: its local map's data (landmarks, keyframes, the current frame's
// features bucketed for radius searches, associations) and Tracker::Impl, whose methods live in
// one file per job: tracker.cpp (per frame), tracker_search.cpp (projection search, pose,
// relocalization), tracker_local_map.cpp (local map, culling, new maps), tracker_keyframes.cpp
// (keyframe policy, final keyframes), tracker_worker.cpp (local bundle adjustment and its
// thread), tracker_depth_calibration.cpp (depth self-calibration).
#pragma once

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
#include <optional>
#include <thread>
#include <unordered_map>
#include <utility>
#include <vector>

#include "stillmap/io/timing.h"
#include "stillmap/tracking/tracker.h"

namespace stillmap {

// The share of pixels with a depth reading outside `ignore_mask` (may be empty).
double StaticDepthShare(const cv::Mat& depth_m, const cv::Mat& ignore_mask);

using Clock = std::chrono::steady_clock;

// A 256-bit ORB descriptor as four words, so that the Hamming distance is four popcounts.
using Descriptor = std::array<uint64_t, 4>;

inline Descriptor DescriptorOf(const cv::Mat& descriptors, int row) {
  Descriptor out;
  std::memcpy(out.data(), descriptors.ptr<uint8_t>(row), sizeof(out));
  return out;
}

inline int HammingDistance(const Descriptor& a, const Descriptor& b) {
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

struct Tracker::Impl {
  Impl(const Camera& camera_in, const TrackerOptions& options_in);
  ~Impl();
  Impl(const Impl&) = delete;
  Impl& operator=(const Impl&) = delete;

  struct PoseEstimate {
    bool ok = false;
    Eigen::Isometry3d camera_from_world = Eigen::Isometry3d::Identity();
    int matches = 0;
    int inliers = 0;
    double rmse_px = 0.0;
  };

  // ---- Per frame: the pose, the bookkeeping of a tracked frame, observations (tracker.cpp)
  double OctaveScale(int octave) const;
  // The i-th feature as an observation, its depth corrected (depth_correction.h) or raw.
  // A relocalized pose is plausible: near the last good pose, given the time since (options).
  bool NearLastGoodPose(const Eigen::Isometry3d& camera_from_world, double time) const;
  RgbdObservation Observation(const FrameFeatures& features, size_t i,
                              bool raw_depth = false) const;
  double DepthFactor(const Eigen::Vector2d& normalized) const;
  bool UsableDepth(float depth) const;
  TrackResult Track(size_t frame_index, double time, const cv::Mat& gray, const cv::Mat& depth_m,
                    const cv::Mat& ignore_mask);
  // Visible / found counts for landmark culling.
  void CountVisibility(const Eigen::Isometry3d& camera_from_world, const LocalSet& local,
                       const Association& association);
  // Bookkeeping for a frame with a pose.
  void Accept(const Eigen::Isometry3d& camera_from_world, double time,
              const std::vector<int>& matched, TrackResult* result);

  // ---- The local map: its landmarks, culling, a new map after a loss (tracker_local_map.cpp)
  LocalSet CollectLocalLandmarks();
  // ORB-SLAM2's culling of recent map points: found in under a quarter of the frames where they
  // were visible, or seen by a single keyframe two keyframes after their creation.
  void CullRecentLandmarks(int current_keyframe);
  void EraseLandmark(int id);
  // A new local map whose first keyframe is this frame at camera_from_world.
  void StartMap(const Eigen::Isometry3d& camera_from_world, FrameData& frame, size_t frame_index,
                double time, std::unique_lock<std::mutex>& lock);

  // ---- Projection search, pose estimation and relocalization (tracker_search.cpp)
  // Projects the local landmarks not matched yet with camera_from_world and matches each to the
  // closest descriptor within radius_px (scaled by the landmark's octave). A feature keeps the
  // landmark with the smallest distance.
  void SearchByProjection(const Eigen::Isometry3d& camera_from_world, const LocalSet& local,
                          double radius_px, const FrameData& frame, Association* association);
  // The associated features and their landmarks' positions.
  void GatherAssociations(const Association& association, std::vector<size_t>* features,
                          std::vector<Eigen::Vector3d>* points) const;
  // Motion-only refinement over the associations; drops the outliers from `association`.
  PoseEstimate Refine(const Eigen::Isometry3d& initial, const FrameData& frame,
                      Association* association, const RefinementOptions& refinement);
  // PnP-RANSAC on the associations (falling back to `guess` when allowed), a short refinement, a
  // second projection search around that pose for landmarks not matched yet, and the full
  // refinement over all associations.
  PoseEstimate EstimatePose(const Eigen::Isometry3d& guess, bool guess_usable,
                            const LocalSet& local, const FrameData& frame,
                            Association* association);
  void Unmatch(size_t feature, Association* association);
  // Descriptor matching against the landmarks of recent keyframes, newest first.
  PoseEstimate Relocalize(const FrameData& frame, Association* association);
  void ClearMatches(Association& association);

  // ---- Keyframe policy and insertion, final keyframes (tracker_keyframes.cpp)
  bool NeedKeyframe(const FrameData& frame, const Association& association, int inliers) const;
  int InsertKeyframe(const Eigen::Isometry3d& camera_from_world, FrameData& frame,
                     const Association& association, size_t frame_index, double time,
                     std::unique_lock<std::mutex>& lock);
  // Keyframes older than both the current window and the window of a running adjustment are
  // final.
  void UpdateFinal(bool all = false);

  // ---- The local bundle adjustment and its worker thread (tracker_worker.cpp)
  // An adjustment is requested at each keyframe with the window as it stands then, solved on the
  // worker (or at once without one), and its result taken at a point fixed by the data: before
  // the frame bundle_adjustment_handover_frames after the request, or the next keyframe, a new
  // map or Finish, whichever comes first. The tracker waits there when the solve is late, so the
  // poses never depend on how fast the worker was.
  struct ObservationRef {
    int keyframe_id, feature, landmark_id;
  };
  struct SolvedWindow {
    BundleAdjustmentResult result;
    std::exception_ptr error;
    double ms = 0.0;
  };
  struct WindowAdjustment {
    BundleAdjustmentProblem problem;  // moved to the solver
    std::vector<int> keyframe_ids, landmark_ids;
    std::vector<ObservationRef> refs;  // per observation of the problem
    std::vector<bool> fixed;           // per keyframe of the problem
    bool calibrating = false;          // the depth correction is estimated jointly
    int window_first = INT_MAX;        // first keyframe id of the window
    size_t handover_serial = 0;        // taken before the frame with this frame_serial
    bool is_solved = false;
    SolvedWindow solved;
  };
  void WorkerLoop();
  SolvedWindow Solve(BundleAdjustmentProblem problem) const;
  // The current window's problem; nothing when the map has fewer than two keyframes.
  std::optional<WindowAdjustment> PrepareAdjustment() const;
  // Prepares an adjustment and hands it to the worker (or solves it at once without one).
  void RequestAdjustment();
  // Takes the pending adjustment's result (waiting for it when needed) and writes it back.
  void TakeAdjustment(std::unique_lock<std::mutex>& lock);
  void ApplyAdjustment(const WindowAdjustment& adjustment);
  void RejectObservation(const ObservationRef& ref);

  // ---- Depth self-calibration (tracker_depth_calibration.cpp)
  // Refits the depth correction from every pair of consecutive observations with depth of the
  // local map's landmarks (raw depths, current keyframe poses).
  void CalibrateDepth();
  // Solves a local bundle adjustment problem; one that estimates the depth correction returns
  // it only when the window pins it down (else it is solved again with the correction fixed).
  BundleAdjustmentResult SolveWindow(BundleAdjustmentProblem problem) const;

  // ---- State
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
  int consecutive_predicted = 0;  // frames posed by the motion model in a row
  double last_good_time = 0.0;
  int frames_since_keyframe = 0;
  std::vector<int> last_frame_landmarks;
  std::vector<FrameRecord> records;
  TrackerStatistics stats;
  // Normalized coordinates of the image's corners, edge midpoints and centre: where the depth
  // correction is bounded.
  std::vector<Eigen::Vector2d> image_outline;

  std::thread worker;
  std::condition_variable wake;     // the worker waits for a request
  std::condition_variable ba_done;  // TakeAdjustment waits for the worker
  bool ba_requested = false;        // the pending adjustment waits for the worker
  bool ba_running = false;
  bool stopping = false;
  std::optional<WindowAdjustment> pending;  // requested, not taken yet
  int running_window_first = INT_MAX;       // first keyframe id of the pending one's window
};

}  // namespace stillmap
