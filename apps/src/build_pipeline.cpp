#include "stillmap/apps/build_pipeline.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <sys/resource.h>

#include <chrono>
#include <deque>
#include <filesystem>
#include <fstream>
#include <future>
#include <map>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <sstream>
#include <thread>
#include <unordered_set>

#include "stillmap/apps/progress.h"
#include "stillmap/apps/report_html.h"
#include "stillmap/io/error.h"
#include "stillmap/io/evaluation.h"
#include "stillmap/io/file_list.h"
#include "stillmap/io/image_io.h"
#include "stillmap/io/input_files.h"
#include "stillmap/io/output_files.h"
#include "stillmap/io/sequence.h"
#include "stillmap/io/trajectory.h"
#include "stillmap/mapping/map_io.h"
#include "stillmap/mapping/map_quality.h"
#include "stillmap/mapping/mapper.h"
#include "stillmap/mapping/occupancy_grid.h"
#include "stillmap/tracking/detector.h"
#include "stillmap/tracking/dynamic_mask.h"
#include "stillmap/tracking/tracker.h"
#include "stillmap/viewer/map_mesh.h"
#include "stillmap/viewer/renders.h"
#include "stillmap/viewer/trajectory_plot.h"

namespace stillmap {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

double Seconds(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

double PeakMemoryMib() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return static_cast<double>(usage.ru_maxrss) / 1024.0;  // ru_maxrss is in KiB on Linux
}

// Every top-level name a build writes (folders end with '/'): a rerun replaces all of them, so
// that no file of an earlier run stays beside the new set (a grid when the OctoMap is now off).
const std::vector<std::string>& BuildOutputNames() {
  static const std::vector<std::string> kNames = {
      "map.ply",  "map.pcd",     "map.bt",      "map.ot",     "trajectory.txt", "keyframes.txt",
      "grid.pgm", "grid.yaml",   "mesh.glb",    "mesh.obj",   "mesh.mtl",       "mesh.ply",
      "renders/", "config.yaml", "report.json", "report.html"};
  return kNames;
}

nlohmann::json CameraJson(const Camera& camera) {
  nlohmann::json json = {
      {"width", camera.width},
      {"height", camera.height},
      {"fx", camera.fx},
      {"fy", camera.fy},
      {"cx", camera.cx},
      {"cy", camera.cy},
      {"distortion", camera.distortion},
      {"depth_factor", camera.depth_factor},
      {"groundtruth_body_from_camera", camera.groundtruth_body_from_camera.has_value()}};
  return json;
}

// A decoded frame with the work that needs nothing but its images: its gray image and, when
// masking tracks flow, the flow step from the previous frame.
struct PreparedFrame {
  Frame frame;
  cv::Mat gray;
  std::optional<FlowStep> flow;
};

// Decodes and prepares frames in order, the next one ahead on another thread when threads > 1.
class FrameReader {
 public:
  FrameReader(const Sequence& sequence, std::vector<size_t> indices, bool read_ahead,
              std::optional<FlowTracker> flow)
      : sequence_(sequence),
        indices_(std::move(indices)),
        read_ahead_(read_ahead),
        flow_(std::move(flow)) {
    if (read_ahead_ && !indices_.empty()) Schedule(0);
  }
  size_t size() const { return indices_.size(); }
  // The k-th frame (k counts up from 0 by one on each call).
  PreparedFrame Get(size_t k) {
    const Clock::time_point start = Clock::now();
    PreparedFrame frame = read_ahead_ ? next_.get() : Prepare(indices_[k]);
    wait_s_ += Seconds(start);
    if (read_ahead_ && k + 1 < indices_.size()) Schedule(k + 1);
    if (frame.flow) flow_ms_.push_back(frame.flow->ms);
    return frame;
  }
  double wait_s() const { return wait_s_; }
  const std::vector<double>& flow_ms() const { return flow_ms_; }

 private:
  PreparedFrame Prepare(size_t index) {
    PreparedFrame prepared;
    prepared.frame = sequence_.LoadFrame(index);
    cv::cvtColor(prepared.frame.color, prepared.gray, cv::COLOR_BGR2GRAY);
    if (flow_) prepared.flow = flow_->Next(prepared.gray);
    return prepared;
  }
  void Schedule(size_t k) {
    next_ = std::async(std::launch::async, [this, index = indices_[k]] { return Prepare(index); });
  }
  const Sequence& sequence_;
  std::vector<size_t> indices_;
  bool read_ahead_;
  std::optional<FlowTracker> flow_;  // used by one Prepare at a time, frames in order
  std::future<PreparedFrame> next_;
  double wait_s_ = 0.0;
  std::vector<double> flow_ms_;
};

double Median(std::vector<double> values) {
  if (values.empty()) return 0.0;
  const size_t middle = values.size() / 2;
  std::nth_element(values.begin(), values.begin() + static_cast<long>(middle), values.end());
  return values[middle];
}

nlohmann::json StatisticsJson(const ErrorStatistics& statistics, double scale) {
  return {{"count", statistics.count},
          {"rmse", statistics.rmse * scale},
          {"mean", statistics.mean * scale},
          {"median", statistics.median * scale},
          {"std_dev", statistics.std_dev * scale},
          {"min", statistics.min * scale},
          {"max", statistics.max * scale}};
}

MapperFrame ToMapperFrame(const Frame& frame, const cv::Mat& mask,
                          const Eigen::Isometry3d& world_from_camera) {
  MapperFrame input;
  input.time = frame.time;
  input.color = frame.color;
  input.depth_m = frame.depth_m;
  input.mask = mask;
  input.world_from_camera = world_from_camera;
  return input;
}

// Per-frame tracking figures, summarized for the report.
struct TrackingRecord {
  std::vector<double> extract_ms, match_ms, pose_ms, keyframe_ms, total_ms;
  std::map<std::string, size_t> status_counts;
  std::vector<double> lost_times;       // frames without a pose [s]
  double fuse_ms = 0.0;                 // fusing final keyframes into the map, on the main thread
  size_t rechecked_with_additions = 0;  // keyframes the map re-check added moving pixels to
};

enum class SelectionVerdict { kFused, kInvalid, kRedundant };

nlohmann::json TimingJson(const std::vector<double>& values) {
  double total = 0.0;
  for (double value : values) total += value;
  return {{"median", Median(values)},
          {"mean", values.empty() ? 0.0 : total / static_cast<double>(values.size())},
          {"total", total}};
}

nlohmann::json DepthCalibrationJson(const TrackerStatistics& t, const TrackerOptions& options) {
  if (!options.depth_self_calibration) return {{"enabled", false}};
  const auto& p = t.depth_correction.coefficients;
  const DepthCorrectionFit& last = t.last_depth_calibration;
  return {{"enabled", true},
          {"model", "z_true = z (1 + p1 x + p2 y + p3 x^2 + p4 y^2 + p5 x y), x, y normalized"},
          {"coefficients", {p[0], p[1], p[2], p[3], p[4]}},
          {"fits_accepted", t.depth_calibrations},
          {"fits_refused", t.depth_calibrations_refused},
          {"time_ms_total", t.depth_calibration_ms},
          {"last_fit",
           {{"accepted", last.ok},
            {"pairs", last.pairs},
            {"pairs_used", last.pairs_used},
            {"spread_before_m", last.spread_before_m},
            {"spread_after_m", last.spread_after_m}}}};
}

// Ground-truth masks of moving pixels (synthetic sequences: masks.txt + masks/), by timestamp.
class TruthMasks {
 public:
  explicit TruthMasks(const std::string& sequence_dir) {
    const fs::path list = fs::path(sequence_dir) / "masks.txt";
    if (!PathExists(list.string())) return;
    for (const StampedPath& entry : ReadFileList(list.string())) {
      times_.push_back(entry.time);
      paths_.push_back((fs::path(sequence_dir) / entry.path).string());
    }
  }
  bool available() const { return !times_.empty(); }
  // The mask of the frame at `time` (CV_8UC1, non-zero = moving), or empty when none is listed
  // within 1 ms. Throws InputError for an unreadable mask.
  cv::Mat Get(double time) const {
    if (times_.empty()) return cv::Mat();
    const size_t i = FindClosestIndex(times_, time);
    if (std::abs(times_[i] - time) > 1e-3) return cv::Mat();
    CheckInputFile(paths_[i], "mask listed in masks.txt");
    cv::Mat mask = cv::imread(paths_[i], cv::IMREAD_UNCHANGED);
    if (mask.empty() || mask.type() != CV_8UC1) {
      throw InputError(paths_[i] + ": not a readable 8-bit mask PNG (listed in masks.txt)");
    }
    return mask;
  }

 private:
  std::vector<double> times_;
  std::vector<std::string> paths_;
};

std::unique_ptr<Detector> MakeDetector(const BuildRequest& request) {
  const std::string& name = request.detector;
  if (name == "none" || name.empty()) return nullptr;
  if (request.models_dir.empty()) {
    throw InputError("--detector " + name +
                     " needs the models: pass --models DIR (the folder holding yolox_nano/ and "
                     "deeplabv3_mnv2_voc/) or set STILLMAP_MODELS");
  }
  const MotionLevelTable levels = MotionLevels(request.config);
  if (name == "yolox") return MakeYoloxDetector(request.models_dir, levels, request.config.yolox);
  if (name == "deeplab") return MakeDeeplabDetector(request.models_dir, levels);
  if (name == "both") {
    return MakeCombinedDetector(MakeYoloxDetector(request.models_dir, levels, request.config.yolox),
                                MakeDeeplabDetector(request.models_dir, levels));
  }
  throw InputError("--detector " + name + ": expected none, yolox, deeplab or both");
}

// The dynamic-rejection stage of a build: detector, masker, ground-truth mask scores and the
// per-frame figures for the report.
class MaskStage {
 public:
  MaskStage(const BuildRequest& request, const Camera& camera)
      : enabled_(request.config.masking_enabled),
        options_(request.config.masking),
        truth_(request.sequence_dir) {
    if (!enabled_) return;
    detector_ = MakeDetector(request);
    masker_ = std::make_unique<DynamicMasker>(camera, options_);
  }
  bool enabled() const { return enabled_; }
  const DynamicMasker* masker() const { return masker_.get(); }

  // The mask of a frame (empty when masking is off), scored against the truth when there is one.
  cv::Mat Compute(const PreparedFrame& prepared,
                  const std::optional<Eigen::Isometry3d>& world_from_camera) {
    const Frame& frame = prepared.frame;
    if (!enabled_) return cv::Mat();
    std::vector<Detection> detections;
    const bool detect = detector_ != nullptr && options_.semantics &&
                        frames_ % static_cast<size_t>(options_.detector_interval) == 0;
    if (detect) {
      const Clock::time_point start = Clock::now();
      detections = detector_->Detect(frame.color);
      detector_ms_.push_back(Seconds(start) * 1000.0);
      for (const Detection& detection : detections) ++detected_[MotionLevelName(detection.level)];
    }
    const DynamicMaskResult result =
        masker_->Compute(prepared.gray, frame.depth_m, world_from_camera,
                         detect ? &detections : nullptr, prepared.flow ? &*prepared.flow : nullptr);
    ++frames_;
    mask_ms_.push_back(result.ms);
    share_sum_ += result.share;
    depth_seeds_ += static_cast<size_t>(result.depth_seeds);
    flow_seeds_ += static_cast<size_t>(result.flow_seeds);
    high_regions_ += static_cast<size_t>(result.high_regions);
    high_confirmed_ += static_cast<size_t>(result.high_confirmed);
    medium_moving_ += static_cast<size_t>(result.medium_moving);
    medium_static_ += static_cast<size_t>(result.medium_static);
    geometric_only_ += static_cast<size_t>(result.geometric_only_regions);
    frames_with_mask_ += result.share > 0.0 ? 1 : 0;
    if (truth_.available()) {
      const cv::Mat truth = truth_.Get(frame.time);
      if (!truth.empty() && truth.size() == result.mask.size()) score_.Add(result.mask, truth);
    }
    return result.mask;
  }

  void AddReference(const Frame& frame, const cv::Mat& mask,
                    const Eigen::Isometry3d& world_from_camera) {
    if (!enabled_) return;
    masker_->AddReference({frame.time, frame.depth_m, mask, world_from_camera, cv::Mat()});
  }

  double MeanShare() const { return frames_ > 0 ? share_sum_ / static_cast<double>(frames_) : 0.0; }
  bool scored() const {
    return score_.frames > 0 || score_.true_positive + score_.false_positive > 0;
  }
  const MaskScore& score() const { return score_; }

  nlohmann::json Json() const {
    nlohmann::json json = {{"enabled", enabled_}};
    if (!enabled_) return json;
    json["detector"] = detector_ ? detector_->name() : "none";
    json["semantics"] = options_.semantics && detector_ != nullptr;
    json["depth_check"] = options_.depth_check;
    json["flow_check"] = options_.flow_check;
    json["outline"] = OutlineModeName(options_.outline);
    json["detector_interval"] = options_.detector_interval;
    json["frames"] = frames_;
    json["frames_with_moving_pixels"] = frames_with_mask_;
    json["mean_masked_share"] = MeanShare();
    json["detections_by_level"] = detected_;
    json["high_level_regions"] = high_regions_;
    json["high_level_confirmed_by_geometry"] = high_confirmed_;
    json["medium_level_moving"] = medium_moving_;
    json["medium_level_static"] = medium_static_;
    json["geometric_regions_outside_detections"] = geometric_only_;
    json["depth_check_seed_pixels"] = depth_seeds_;
    json["flow_check_seed_points"] = flow_seeds_;
    return json;
  }
  nlohmann::json TimingsJson() const {
    return {{"detector", TimingJson(detector_ms_)}, {"mask", TimingJson(mask_ms_)}};
  }

 private:
  bool enabled_;
  DynamicMaskOptions options_;
  TruthMasks truth_;
  std::unique_ptr<Detector> detector_;
  std::unique_ptr<DynamicMasker> masker_;
  MaskScore score_;
  size_t frames_ = 0, frames_with_mask_ = 0;
  double share_sum_ = 0.0;
  size_t depth_seeds_ = 0, flow_seeds_ = 0, high_regions_ = 0, high_confirmed_ = 0;
  size_t medium_moving_ = 0, medium_static_ = 0, geometric_only_ = 0;
  std::map<std::string, size_t> detected_;
  std::vector<double> detector_ms_, mask_ms_;
};

// Refuses ground-truth poses the maps cannot hold (a motion-capture world far from its origin):
// OctoMap's keys reach +-1.6 km at 5 cm, and beyond them every insertion would be dropped.
void CheckWithinMapExtent(const std::vector<StampedPose>& poses, const BuildConfig& config) {
  double farthest = 0.0;
  for (const StampedPose& pose : poses) {
    farthest = std::max(farthest, pose.world_from_camera.translation().cwiseAbs().maxCoeff());
  }
  const double reach = farthest + config.mapping.back_projection.max_depth;
  const double extent = config.mapping.Extent();
  if (reach >= extent) {
    throw InputError(fmt::format(
        "groundtruth.txt: the camera lies up to {:.0f} m from the ground truth's origin along an "
        "axis, but the maps reach {:.0f} m (octomap.resolution {} m, mapping.voxel_leaf {} m); "
        "shift the ground truth nearer its origin or coarsen the maps",
        farthest, extent, config.mapping.occupancy.resolution, config.mapping.voxel.leaf_size));
  }
}

// Warnings about the finished map that the figures alone do not make plain.
void AddResultWarnings(const std::optional<TrackerStatistics>& tracking, Mapper& mapper,
                       BuildSummary* summary) {
  if (tracking && tracking->new_maps > 0) {
    summary->warnings.push_back(fmt::format(
        "tracking was lost and not relocalized {} time(s); each time a new local map was started "
        "from the last good pose and fused into the same cloud, so parts of the map may be "
        "misaligned copies (report.json: tracking.lost_frame_times)",
        tracking->new_maps));
  }
  const size_t cloud_out = mapper.cloud().rejected_count();
  const size_t octomap_out = mapper.occupancy() ? mapper.occupancy()->rejected_count() : 0;
  if (cloud_out + octomap_out > 0) {
    summary->warnings.push_back(fmt::format(
        "{} points of the voxel cloud and {} of the OctoMap lay beyond the maps' extent ({:.0f} m "
        "from the origin) and were left out: the poses went far astray",
        cloud_out, octomap_out, mapper.options().Extent()));
  }
}

// Why a build ends without a map, from the figures that explain it: an empty map is a failed run
// (exit 1, nothing written), not a set of empty files that look like a result.
std::string EmptyMapMessage(Mapper& mapper, const MapCleaningResult& cleaning,
                            const MaskStage& masks) {
  const MapperStatistics& stats = mapper.statistics();
  const MapperOptions& options = mapper.options();
  std::string message = fmt::format(
      "the map is empty: {} frames fused, {} depth readings within [{}, {}] m (mapping.min_depth, "
      "mapping.max_depth) outside the masks",
      stats.frames, stats.points, options.back_projection.min_depth,
      options.back_projection.max_depth);
  if (mapper.cloud().rejected_count() > 0) {
    message += fmt::format(", {} of them beyond the voxel grid's range (poses far from the origin)",
                           mapper.cloud().rejected_count());
  }
  const size_t cleaned = cleaning.seen_through + cleaning.seen_through_views + cleaning.outliers;
  if (cleaned > 0) message += fmt::format(", {} voxels removed by the map cleaning", cleaned);
  if (masks.enabled()) {
    message +=
        fmt::format("; {:.1f} % of the pixels were masked as moving", 100 * masks.MeanShare());
  }
  return message + ". Check the depth scale (camera.depth_factor), the depth range and the poses";
}

}  // namespace

BuildSummary RunBuild(const BuildRequest& request) {
  const Clock::time_point start = Clock::now();
  const BuildConfig& config = request.config;
  config.Validate();
  if (request.threads < 1) throw InputError("--threads must be at least 1");
  // OpenCV's own parallel loops (the depth check, KLT, ORB's pyramid) use as many threads, at
  // most one per core: TBB, OpenCV's backend, warns on stderr about more, even under --quiet.
  const int cores = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  cv::setNumThreads(std::min(request.threads, cores));
  std::error_code folder_error;
  if (!fs::is_directory(request.sequence_dir, folder_error)) {
    throw InputError(request.sequence_dir +
                     ": sequence folder not found (expected a TUM-layout folder with rgb.txt and "
                     "depth.txt)");
  }
  const bool tracking = request.poses == PoseSource::kTracking;

  // Inputs are checked before anything is written.
  const Camera camera = ResolveCamera(request.sequence_dir, config.camera);
  const Sequence sequence = Sequence::Open(request.sequence_dir, camera, config.sequence);
  if (!tracking && !sequence.groundtruth()) {
    throw InputError(request.sequence_dir +
                     ": no groundtruth.txt; --poses groundtruth needs the sequence's ground truth");
  }
  const size_t total_pairs = sequence.frames().size();
  if (config.first_frame >= total_pairs) {
    throw InputError("sequence.first_frame=" + std::to_string(config.first_frame) +
                     " but the sequence has " + std::to_string(total_pairs) + " color/depth pairs");
  }
  const size_t end = config.max_frames == 0
                         ? total_pairs
                         : std::min(total_pairs, config.first_frame + config.max_frames);

  // With ground-truth poses, frames without one are not decoded at all.
  std::vector<size_t> frame_indices;
  std::vector<StampedPose> groundtruth_poses;
  for (size_t i = config.first_frame; i < end; ++i) {
    if (tracking) {
      frame_indices.push_back(i);
      continue;
    }
    const double time = sequence.frames()[i].time;
    const std::optional<Eigen::Isometry3d> world_from_camera =
        sequence.groundtruth()->Interpolate(time, config.sequence.max_groundtruth_gap);
    if (!world_from_camera) continue;
    frame_indices.push_back(i);
    groundtruth_poses.push_back({time, *world_from_camera});
  }
  BuildSummary summary;
  summary.frames_paired = end - config.first_frame;
  summary.frames_without_pose = summary.frames_paired - frame_indices.size();
  if (frame_indices.empty()) {
    throw InputError(request.sequence_dir +
                     ": no frame lies within the ground truth's time range (compare the timestamps "
                     "of rgb.txt and groundtruth.txt)");
  }
  if (!tracking) CheckWithinMapExtent(groundtruth_poses, config);
  if (summary.frames_without_pose > 0) {
    spdlog::warn(
        "{} of {} frames lie outside the ground truth (or across a gap wider than {} s) "
        "and are left out",
        summary.frames_without_pose, summary.frames_paired, config.sequence.max_groundtruth_gap);
  }

  MaskStage masks(request, camera);  // loads the detector: its errors come before any output

  // Locks the output folder and stages the outputs aside until all are written.
  OutputSet outputs(request.output_dir, BuildOutputNames());
  if (!outputs.recovery_note().empty()) summary.warnings.push_back(outputs.recovery_note());

  MapperOptions mapper_options = config.mapping;
  mapper_options.in_background = request.threads > 1;
  Mapper mapper(camera, mapper_options);
  ProgressLine progress("stillmap build", frame_indices.size(), request.show_progress);
  std::optional<FlowTracker> flow;
  if (config.masking_enabled && config.masking.TracksFlow()) {
    flow.emplace(config.masking.flow_points, config.masking.flow);
  }
  FrameReader reader(sequence, frame_indices, request.threads > 1, std::move(flow));

  std::vector<StampedPose> keyframe_poses;  // the frames fused, with the poses they were fused at
  Trajectory trajectory;
  TrackingRecord record;
  std::optional<TrackerStatistics> tracker_statistics;
  if (!tracking) {
    // Every frame is fused; every fifth one becomes a depth-check reference.
    for (size_t k = 0; k < reader.size(); ++k) {
      const PreparedFrame prepared = reader.Get(k);
      const Frame& frame = prepared.frame;
      const Eigen::Isometry3d& pose = groundtruth_poses[k].world_from_camera;
      const cv::Mat mask = masks.Compute(prepared, pose);
      if (k % 5 == 0) masks.AddReference(frame, mask, pose);
      mapper.Integrate(ToMapperFrame(frame, mask, pose));
      progress.Update(k + 1);
    }
    trajectory = Trajectory(groundtruth_poses);
    keyframe_poses = groundtruth_poses;
  } else {
    // Keyframes are fused once their pose is final (they left the bundle adjustment window);
    // their images wait here until then.
    TrackerOptions tracker_options = config.tracking;
    if (request.threads == 1) tracker_options.background_bundle_adjustment = false;
    Tracker tracker(camera, tracker_options);
    struct Waiting {
      Frame frame;
      MaskReference reference;  // its mask and pose at tracking time, for the map re-check
    };
    std::map<int, Waiting> waiting;
    std::deque<MaskReference> recent;  // keyframes already considered, final poses, oldest first
    std::unordered_set<int> selected_landmarks;
    const double spacing = config.masking.reference_spacing_s;
    const size_t max_references = 2 * static_cast<size_t>(config.masking.reference_keyframes);
    DepthFactorImages factors(camera);  // of the tracker's depth correction
    auto fuse = [&](const std::vector<FinalKeyframe>& finals) {
      const Clock::time_point fuse_start = Clock::now();
      for (const FinalKeyframe& keyframe : finals) {
        const auto it = waiting.find(keyframe.id);
        if (it == waiting.end()) continue;
        const Frame& frame = it->second.frame;
        cv::Mat mask = it->second.reference.mask;
        bool mask_changed = false;
        if (masks.enabled() && config.map_recheck && config.masking.depth_check) {
          // References on both sides in time: earlier keyframes (final poses) and later ones
          // still in the window (their current poses), each side spread by the spacing.
          std::vector<const MaskReference*> newest_first;
          for (auto earlier = recent.rbegin(); earlier != recent.rend(); ++earlier) {
            newest_first.push_back(&*earlier);
          }
          std::vector<const MaskReference*> references =
              SpreadInTime(newest_first, spacing, max_references);
          double last = keyframe.time;
          for (auto next = std::next(it); next != waiting.end(); ++next) {
            MaskReference& later = next->second.reference;
            const bool newest = std::next(next) == waiting.end();
            if (later.time - last < spacing && !newest) continue;
            last = later.time;
            if (references.size() >= max_references) continue;
            if (later.nearest_depth_m.empty()) later.nearest_depth_m = NearestStaticDepth(later);
            references.push_back(&later);
          }
          cv::Mat recheck = masks.masker()->geometry().Compute(
              frame.depth_m, keyframe.world_from_camera, references);
          if (cv::countNonZero(recheck) > 0) {
            const int size = 2 * config.masking.margin_px + 1;
            cv::dilate(recheck, recheck,
                       cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(size, size)));
            mask = mask.empty() ? recheck : (mask | recheck);
            mask_changed = true;
            ++record.rechecked_with_additions;
          }
        }
        const double share = mask.empty() ? 0.0
                                          : static_cast<double>(cv::countNonZero(mask)) /
                                                static_cast<double>(mask.total());
        size_t shared = 0;
        for (int id : keyframe.landmarks) shared += selected_landmarks.count(id);
        const SelectionVerdict verdict =
            !config.selection.enabled                   ? SelectionVerdict::kFused
            : share > config.selection.max_masked_share ? SelectionVerdict::kInvalid
            : !keyframe.landmarks.empty() &&
                    static_cast<double>(shared) > config.selection.max_shared_landmarks *
                                                      static_cast<double>(keyframe.landmarks.size())
                ? SelectionVerdict::kRedundant
                : SelectionVerdict::kFused;
        if (verdict == SelectionVerdict::kFused) {
          MapperFrame input = ToMapperFrame(frame, mask, keyframe.world_from_camera);
          // The depth corrected as the tracker's self-calibration has it now (the poses are
          // consistent with it).
          const DepthCorrection correction = tracker.statistics().depth_correction;
          if (!correction.IsIdentity()) input.depth_m = frame.depth_m.mul(factors.For(correction));
          mapper.Integrate(input);
          keyframe_poses.push_back({keyframe.time, keyframe.world_from_camera});
          selected_landmarks.insert(keyframe.landmarks.begin(), keyframe.landmarks.end());
        } else if (verdict == SelectionVerdict::kInvalid) {
          ++summary.keyframes_invalid;
        } else {
          ++summary.keyframes_redundant;
        }
        if (config.map_recheck) {
          MaskReference& done = recent.emplace_back(std::move(it->second.reference));
          done.mask = mask;
          done.world_from_camera = keyframe.world_from_camera;  // final
          if (mask_changed || done.nearest_depth_m.empty()) {
            done.nearest_depth_m = NearestStaticDepth(done);
          }
          while (recent.size() > 1 &&
                 recent.back().time - recent.front().time > config.masking.ReferenceHorizonS()) {
            recent.pop_front();
          }
        }
        waiting.erase(it);
      }
      record.fuse_ms += Seconds(fuse_start) * 1000.0;
    };
    for (size_t k = 0; k < reader.size(); ++k) {
      PreparedFrame prepared = reader.Get(k);
      Frame& frame = prepared.frame;
      const cv::Mat mask = masks.Compute(prepared, tracker.PredictedPose());
      const TrackResult result =
          tracker.Track(frame.index, frame.time, prepared.gray, frame.depth_m, mask);
      record.extract_ms.push_back(result.timings.extract_ms);
      record.match_ms.push_back(result.timings.match_ms);
      record.pose_ms.push_back(result.timings.pose_ms);
      record.keyframe_ms.push_back(result.timings.keyframe_ms);
      record.total_ms.push_back(result.timings.total_ms);
      ++record.status_counts[TrackStatusName(result.status)];
      if (!result.tracked()) record.lost_times.push_back(frame.time);
      if (result.keyframe_id >= 0) {
        masks.AddReference(frame, mask, result.world_from_camera);
        MaskReference reference{frame.time, frame.depth_m, mask, result.world_from_camera,
                                cv::Mat()};
        waiting.emplace(result.keyframe_id, Waiting{std::move(frame), std::move(reference)});
      }
      fuse(tracker.TakeFinalKeyframes());
      progress.Update(k + 1);
    }
    tracker.Finish();
    fuse(tracker.TakeFinalKeyframes());
    trajectory = tracker.TrackedTrajectory();
    tracker_statistics = tracker.statistics();
    if (trajectory.empty()) {
      throw std::runtime_error(
          "no frame could be tracked (too few ORB features with depth: is the depth scale right? "
          "see camera.depth_factor)");
    }
  }
  mapper.Finish();
  progress.Finish();
  const double processing_s = Seconds(start);

  // The outputs, each under a temporary name until all are written. The cloud is cleaned against
  // the final OctoMap on another thread while the OctoMap and the grid, which only read the
  // OctoMap, are written (Bonn: cleaning 0.4 s, OctoMap files and grid 0.3 s).
  const Clock::time_point write_start = Clock::now();
  MapCleaningResult cleaning;
  double clean_ms = 0.0;
  std::future<void> clean_job =
      std::async(request.threads > 1 ? std::launch::async : std::launch::deferred,
                 [&mapper, &cleaning, &clean_ms] {
                   const Clock::time_point clean_start = Clock::now();
                   cleaning = mapper.CleanCloud();
                   clean_ms = Seconds(clean_start) * 1000.0;
                 });
  if (mapper.occupancy() != nullptr) {
    mapper.WriteOccupancy(outputs.TemporaryPath("map.bt"), outputs.TemporaryPath("map.ot"));
  }
  std::vector<Eigen::Isometry3d> keyframes_in_world;
  keyframes_in_world.reserve(keyframe_poses.size());
  for (const StampedPose& pose : keyframe_poses)
    keyframes_in_world.push_back(pose.world_from_camera);
  // The 2-D grid for planners, from the OctoMap; the floor is fitted to it and checked against
  // the fused cameras' mean up direction (camera -y).
  std::optional<OccupancyGrid> grid;
  double grid_ms = 0.0;
  if (config.grid.enabled && mapper.occupancy() != nullptr) {
    const Clock::time_point grid_start = Clock::now();
    const FloorPlane floor =
        FindFloor(*mapper.occupancy(), MeanCameraUp(keyframes_in_world), config.grid);
    grid = ProjectToGrid(*mapper.occupancy(), floor, config.grid);
    WriteGrid(*grid, outputs.TemporaryPath("grid.pgm"), outputs.TemporaryPath("grid.yaml"),
              "grid.pgm");
    grid_ms = Seconds(grid_start) * 1000.0;
  }
  clean_job.get();
  // The cloud's points, once, for the cloud files, the mesh, the map quality and the renders.
  std::vector<VoxelPoint> cloud_points = mapper.cloud().Points();
  if (cloud_points.empty()) throw std::runtime_error(EmptyMapMessage(mapper, cleaning, masks));
  // The mesh, from the voxel cloud, on another thread while the rest is written.
  std::optional<ColoredMesh> mesh;
  double mesh_ms = 0.0;
  std::future<void> mesh_job;
  if (config.mesh.enabled) {
    const std::string mesh_path = outputs.TemporaryPath(config.mesh.FileName());
    mesh_job = std::async(request.threads > 1 ? std::launch::async : std::launch::deferred,
                          [&mesh, &mesh_ms, &cloud_points, &config, mesh_path] {
                            const Clock::time_point mesh_start = Clock::now();
                            mesh = VoxelSurfaceMesh(cloud_points, config.mesh);
                            if (mesh->faces.empty()) {
                              throw std::runtime_error(fmt::format(
                                  "the mesh is empty: no {} m voxel holds mesh.min_points={} map "
                                  "points; lower mesh.min_points or set mesh.enabled=false",
                                  config.mesh.voxel, config.mesh.min_points));
                            }
                            WriteColoredMesh(mesh_path, *mesh, config.mesh.format);
                            mesh_ms = Seconds(mesh_start) * 1000.0;
                          });
  }
  WriteCloudFiles(outputs.TemporaryPath("map.ply"), outputs.TemporaryPath("map.pcd"), cloud_points,
                  config.mapping.voxel.leaf_size);
  trajectory.WriteTum(outputs.TemporaryPath("trajectory.txt"),
                      tracking ? "stillmap trajectory (camera-to-world, every tracked frame)"
                               : "stillmap trajectory (camera-to-world, ground-truth poses)");
  Trajectory(keyframe_poses)
      .WriteTum(outputs.TemporaryPath("keyframes.txt"),
                tracking ? "stillmap keyframes fused into the map (camera-to-world, final poses)"
                         : "stillmap keyframes fused into the map (every frame with a pose)");
  {
    std::ofstream out(outputs.TemporaryPath("config.yaml"));
    out << ConfigToYaml(config);
    if (!out.flush()) throw std::runtime_error("could not write config.yaml");
  }
  if (mesh_job.valid()) mesh_job.get();
  const double write_s = Seconds(write_start);

  const MapperStatistics& stats = mapper.statistics();
  summary.frames_fused = stats.frames;
  summary.frames_tracked = trajectory.size();
  summary.map_points = mapper.cloud().OutputSize();
  summary.octomap_leaves = mapper.occupancy() ? mapper.occupancy()->LeafCount() : 0;
  summary.wall_time_s = Seconds(start);
  summary.frames_per_second = static_cast<double>(summary.frames_paired) / summary.wall_time_s;
  summary.peak_memory_mib = PeakMemoryMib();

  const double n = static_cast<double>(std::max<size_t>(stats.frames, 1));
  const double frames = static_cast<double>(frame_indices.size());
  nlohmann::json report;
  report["stillmap_version"] = STILLMAP_VERSION;
  report["sequence"] = request.sequence_dir;
  report["poses"] = tracking ? "tracking" : "groundtruth";
  report["world_frame"] =
      tracking ? "the first tracked camera frame" : "the ground truth's world frame";
  report["camera"] = CameraJson(camera);
  report["frames"] = {{"color_images", sequence.color_count()},
                      {"depth_images", sequence.depth_count()},
                      {"pairs_in_sequence", total_pairs},
                      {"pairs_used", summary.frames_paired},
                      {"without_pose", summary.frames_without_pose},
                      {"tracked", summary.frames_tracked},
                      {"fused", summary.frames_fused}};
  summary.dynamic_share = masks.MeanShare();
  report["keyframes"] = {
      {"fused", summary.frames_fused},
      {"rejected_invalid", summary.keyframes_invalid},
      {"rejected_redundant", summary.keyframes_redundant},
      {"map_recheck_added_pixels", record.rechecked_with_additions},
      {"selection",
       !tracking ? "none: with known poses every frame is fused"
       : config.selection.enabled
           ? fmt::format("invalid when more than {} of the frame is masked; redundant when more "
                         "than {} of its landmarks are seen by the keyframes selected before",
                         config.selection.max_masked_share, config.selection.max_shared_landmarks)
           : "off: every tracking keyframe is fused"}};
  report["dynamic_share"] = summary.dynamic_share;
  report["masking"] = masks.Json();
  if (masks.scored()) {
    const MaskScore& score = masks.score();
    summary.mask_precision = score.Precision();
    summary.mask_recall = score.Recall();
    summary.mask_iou = score.Iou();
    report["mask_quality"] = {{"truth", "masks.txt"},
                              {"frames", score.frames},
                              {"precision", score.Precision()},
                              {"recall", score.Recall()},
                              {"iou", score.Iou()},
                              {"mean_frame_iou", score.MeanFrameIou()}};
  }
  report["map"] = {{"voxel_leaf_m", config.mapping.voxel.leaf_size},
                   {"points_fused", stats.points},
                   {"voxels", mapper.cloud().size()},
                   {"voxels_written", summary.map_points},
                   {"voxels_removed_seen_through", cleaning.seen_through},
                   {"voxels_removed_seen_through_views", cleaning.seen_through_views},
                   {"voxels_removed_outliers", cleaning.outliers},
                   {"clear_seen_through_views", config.mapping.cleaning.clear_seen_through_views},
                   {"clear_seen_through",
                    config.mapping.cleaning.clear_seen_through && config.mapping.occupancy_enabled},
                   {"outlier_removal", config.mapping.cleaning.outlier_removal},
                   {"min_points_per_voxel", config.mapping.voxel.min_points_per_voxel},
                   {"voxels_out_of_range", mapper.cloud().rejected_count()},
                   {"voxel_table_mib", mapper.cloud().MemoryBytes() / (1024.0 * 1024.0)},
                   {"octomap_enabled", config.mapping.occupancy_enabled},
                   {"octomap_resolution_m", config.mapping.occupancy.resolution},
                   {"octomap_leaves", summary.octomap_leaves},
                   {"octomap_points_out_of_range",
                    mapper.occupancy() ? mapper.occupancy()->rejected_count() : 0},
                   {"octomap_occupied_leaves",
                    mapper.occupancy() ? mapper.occupancy()->OccupiedLeafCount() : 0}};
  if (mesh) {
    report["mesh"] = {{"file", config.mesh.FileName()},
                      {"voxel_m", config.mesh.voxel},
                      {"voxels", mesh->voxels},
                      {"vertices", mesh->vertices.size()},
                      {"triangles", mesh->faces.size()},
                      {"method",
                       "exposed faces of the occupied voxels, shared corners colored by the voxels "
                       "meeting there"}};
  } else {
    report["mesh"] = nullptr;
  }
  if (grid) {
    const Eigen::Matrix4d m = grid->world_from_grid.matrix();
    std::vector<double> world_from_map;
    for (int r = 0; r < 4; ++r) {
      for (int c = 0; c < 4; ++c) world_from_map.push_back(m(r, c));
    }
    const FloorPlane& floor = grid->floor;
    report["grid"] = {{"files", {"grid.pgm", "grid.yaml"}},
                      {"width", grid->width},
                      {"height", grid->height},
                      {"resolution_m", grid->resolution},
                      {"origin_m", {grid->origin.x(), grid->origin.y()}},
                      {"band_m", {grid->min_height, grid->max_height}},
                      {"cells",
                       {{"free", grid->Count(kGridFree)},
                        {"occupied", grid->Count(kGridOccupied)},
                        {"unknown", grid->Count(kGridUnknown)},
                        {"occupied_unconfirmed_made_unknown", grid->unconfirmed_cells}}},
                      {"frame",
                       "x, y in the floor plane, z up from the floor, origin on the floor below "
                       "the world origin"},
                      {"world_from_map", world_from_map},
                      {"floor",
                       {{"source", floor.source},
                        {"up", {floor.up.x(), floor.up.y(), floor.up.z()}},
                        {"offset_m", floor.offset},
                        {"world_origin_height_m", floor.offset},
                        {"tilt_to_cameras_up_deg", floor.tilt_to_cameras_deg},
                        {"plane_voxels", floor.inliers}}}};
  } else {
    report["grid"] = nullptr;
    report["grid_note"] = config.grid.enabled ? "not written: the OctoMap is off (octomap.enabled)"
                                              : "not written: grid.enabled=false";
  }
  nlohmann::json timing = {{"load_wait_total", reader.wait_s() * 1000.0},
                           {"grid", grid_ms},
                           {"mesh", mesh_ms},
                           {"map_cleaning", clean_ms},
                           {"back_projection_total", stats.back_projection_ms},
                           {"voxel_total", stats.voxel_ms},
                           {"octomap_total", stats.occupancy_ms},
                           {"octomap_wait_total", stats.occupancy_wait_ms},
                           {"fusion_wait_total", stats.wait_ms},
                           {"write_outputs", write_s * 1000.0},
                           {"per_fused_frame",
                            {{"back_projection", stats.back_projection_ms / n},
                             {"voxel", stats.voxel_ms / n},
                             {"octomap", stats.occupancy_ms / n},
                             {"octomap_wait", stats.occupancy_wait_ms / n}}},
                           {"per_frame",
                            {{"load_wait", reader.wait_s() * 1000.0 / frames},
                             {"total", processing_s * 1000.0 / frames}}}};
  if (tracking) {
    const TrackerStatistics& t = *tracker_statistics;
    const double median_track_ms = Median(record.total_ms);
    report["tracking"] = {
        {"frames", t.frames},
        {"tracked", t.tracked},
        {"lost", t.lost},
        {"relocalized", t.relocalized},
        {"new_maps", t.new_maps},
        {"status_counts", record.status_counts},
        {"lost_frame_times", record.lost_times},
        {"keyframes", t.keyframes},
        {"landmarks_alive", t.landmarks},
        {"landmarks_created", t.landmarks_created},
        {"landmarks_culled", t.landmarks_culled},
        {"bundle_adjustments", t.bundle_adjustments},
        {"bundle_adjustment_observations_rejected", t.observations_rejected},
        {"tracking_frames_per_second_median", median_track_ms > 0 ? 1000.0 / median_track_ms : 0},
        {"depth_self_calibration", DepthCalibrationJson(t, config.tracking)},
        {"bundle_adjustment_thread",
         config.tracking.background_bundle_adjustment && request.threads > 1}};
    timing["tracking_ms"] = {
        {"extract", TimingJson(record.extract_ms)},
        {"match", TimingJson(record.match_ms)},
        {"pose", TimingJson(record.pose_ms)},
        {"keyframe", TimingJson(record.keyframe_ms)},
        {"track_total", TimingJson(record.total_ms)},
        {"local_bundle_adjustment",
         {{"runs", t.bundle_adjustments},
          {"mean", t.bundle_adjustments > 0
                       ? t.bundle_adjustment_ms / static_cast<double>(t.bundle_adjustments)
                       : 0.0},
          {"total", t.bundle_adjustment_ms}}},
        {"fuse_keyframes_total", record.fuse_ms}};
  }
  if (masks.enabled()) {
    timing["masking_ms"] = masks.TimingsJson();
    // The flow check's image work runs ahead with the decoding (on the reading thread when
    // threads > 1), so it is not part of "mask".
    timing["masking_ms"]["flow_ahead"] = TimingJson(reader.flow_ms());
  }
  report["timing_ms"] = timing;
  AddResultWarnings(tracker_statistics, mapper, &summary);
  report["warnings"] = summary.warnings;
  report["wall_time_s"] = summary.wall_time_s;
  report["frames_per_second"] = summary.frames_per_second;
  report["peak_memory_mib"] = summary.peak_memory_mib;
  report["threads"] = request.threads;
  // With ground-truth poses the map is in the ground truth's frame. A tracked map is anchored at
  // the first tracked frame: its ground-truth pose times the inverse of its tracked pose (the
  // identity). Not the ATE alignment, whose rotation is ill-determined by positions alone when
  // the camera moves little or along a line.
  std::optional<Eigen::Isometry3d> groundtruth_from_map;
  if (!tracking) {
    groundtruth_from_map = Eigen::Isometry3d::Identity();
  } else if (sequence.groundtruth()) {
    const StampedPose& first = trajectory.poses().front();
    const std::optional<Eigen::Isometry3d> world_from_first =
        sequence.groundtruth()->Interpolate(first.time, config.sequence.max_groundtruth_gap);
    if (world_from_first) {
      groundtruth_from_map = *world_from_first * first.world_from_camera.inverse();
    }
  }
  std::optional<AteResult> ate_result;
  report["trajectory_error"] = nullptr;
  if (!tracking) {
    report["trajectory_error_note"] = "not evaluated: the poses are the ground truth";
  } else if (!sequence.groundtruth()) {
    report["trajectory_error_note"] = "not evaluated: the sequence has no groundtruth.txt";
  } else {
    try {
      const AteResult ate = ComputeAte(*sequence.groundtruth(), trajectory, config.ate);
      summary.ate_rmse = ate.translation.rmse;
      ate_result = ate;
      nlohmann::json error = {{"ate_m", StatisticsJson(ate.translation, 1.0)},
                              {"ate_max_time_difference_s", config.ate.max_time_difference}};
      try {
        const RpeResult rpe = ComputeRpe(*sequence.groundtruth(), trajectory, config.rpe);
        error["rpe_delta_s"] = config.rpe.delta;
        error["rpe_translation_m"] = StatisticsJson(rpe.translation, 1.0);
        error["rpe_rotation_deg"] = StatisticsJson(rpe.rotation, 1.0);
      } catch (const InputError& e) {
        error["rpe_note"] = std::string("not evaluated: ") + e.what();
      }
      report["trajectory_error"] = error;
    } catch (const InputError& e) {
      report["trajectory_error_note"] = std::string("not evaluated: ") + e.what();
    }
  }
  // Map quality against the static ground truth of synthetic sequences (not counted in the
  // frames per second above), in the ground truth's frame (see groundtruth_from_map).
  const fs::path static_groundtruth = fs::path(request.sequence_dir) / "static_gt.ply";
  const bool has_static_groundtruth = PathExists(static_groundtruth.string());
  if (has_static_groundtruth && !groundtruth_from_map) {
    report["map_quality"] = nullptr;
    report["map_quality_note"] =
        "not evaluated: the first tracked frame has no ground-truth pose to anchor the map";
  } else if (has_static_groundtruth) {
    const Clock::time_point evaluation_start = Clock::now();
    std::vector<VoxelPoint> points = cloud_points;
    const Eigen::Isometry3f transform = groundtruth_from_map->cast<float>();
    for (VoxelPoint& point : points) point.position = transform * point.position;
    const std::vector<VoxelPoint> truth = ReadCloud(static_groundtruth.string());
    const MapQuality quality = EvaluateMap(points, truth);
    summary.map_quality = quality;
    report["map_quality"] = {
        {"groundtruth", static_groundtruth.string()},
        {"aligned_by", tracking ? "the ground-truth pose of the first tracked frame"
                                : "nothing: the poses are the ground truth"},
        {"map_points", quality.map_points},
        {"groundtruth_points", quality.groundtruth_points},
        {"accuracy_mean_m", quality.accuracy_mean},
        {"accuracy_median_m", quality.accuracy_median},
        {"completeness", quality.completeness},
        {"ghost_share", quality.ghost_share},
        {"evaluation_s", Seconds(evaluation_start)}};
    if (grid) {
      // The truth's occupancy over the same band, in the map's frame.
      const Eigen::Isometry3d map_from_groundtruth = groundtruth_from_map->inverse();
      std::vector<Eigen::Vector3d> truth_in_map;
      truth_in_map.reserve(truth.size());
      for (const VoxelPoint& point : truth) {
        truth_in_map.push_back(map_from_groundtruth * point.position.cast<double>());
      }
      // Where the moving objects were (objects.txt of synthetic sequences: time, id, name, then
      // the object's floor position), for the cells occupied only because one stood there.
      std::vector<Eigen::Vector3d> moving_in_map;
      const std::string objects_path = (fs::path(request.sequence_dir) / "objects.txt").string();
      if (PathExists(objects_path)) CheckInputFile(objects_path, "object list");
      std::ifstream objects(objects_path);
      for (std::string line; std::getline(objects, line);) {
        if (line.empty() || line[0] == '#') continue;
        std::istringstream fields(line);
        double time = 0.0, x = 0.0, y = 0.0, z = 0.0;
        std::string id, name;
        if (fields >> time >> id >> name >> x >> y >> z) {
          moving_in_map.push_back(map_from_groundtruth * Eigen::Vector3d(x, y, z));
        }
      }
      const GridQuality grid_quality = EvaluateGrid(*grid, truth_in_map, moving_in_map);
      summary.grid_quality = grid_quality;
      report["grid_quality"] = {
          {"observed_cells", grid_quality.observed_cells},
          {"agreement", grid_quality.agreement},
          {"occupied_cells", grid_quality.occupied_cells},
          {"occupied_without_static_truth", grid_quality.false_occupied},
          {"of_those_on_moving_objects_paths",
           moving_in_map.empty() ? nlohmann::json(nullptr)
                                 : nlohmann::json(grid_quality.false_occupied_on_paths)},
          {"path_margin_m", grid_quality.path_margin_m},
          {"free_where_truth_occupied", grid_quality.missed_occupied}};
    }
  }
  // Renders (renders/), not counted in the frames per second above.
  if (config.render.enabled) {
    const Clock::time_point render_start = Clock::now();
    RenderInput input;
    input.cloud = std::move(cloud_points);  // its last use
    input.grid = grid;
    for (const StampedPose& pose : trajectory.poses()) {
      input.trajectory.push_back(pose.world_from_camera);
    }
    input.keyframes = std::move(keyframes_in_world);
    input.title = SequenceName(request.sequence_dir);
    std::vector<std::string> names;
    for (const auto& [name, image] : RenderViews(input)) {
      WriteImage(outputs.TemporaryPath("renders/" + name), image, ".png");
      names.push_back("renders/" + name);
    }
    if (ate_result) {
      WriteImage(outputs.TemporaryPath("renders/trajectory_error.png"),
                 DrawTrajectoryPlot(*ate_result), ".png");
      names.push_back("renders/trajectory_error.png");
    }
    report["renders"] = names;
    report["timing_ms"]["renders"] = Seconds(render_start) * 1000.0;
  } else {
    report["renders"] = nullptr;
  }
  {
    std::ofstream out(outputs.TemporaryPath("report.json"));
    out << report.dump(2) << "\n";
    if (!out.flush()) throw std::runtime_error("could not write report.json");
  }
  {
    std::ofstream out(outputs.TemporaryPath("report.html"));
    out << ReportHtml(report);
    if (!out.flush()) throw std::runtime_error("could not write report.html");
  }
  outputs.Commit();
  return summary;
}

}  // namespace stillmap
