#include "stillmap/tracking/mask_stage.h"

#include <cmath>
#include <filesystem>
#include <map>

#include "stillmap/io/cpu_usage.h"

namespace stillmap {
namespace {

long long Microseconds(double time) { return std::llround(time * 1e6); }

// Times of the frames in which some object of SEQUENCE/objects.txt (when it exists) is where it
// was in the previous frame, within 1 mm and 0.1 degrees.
std::set<long long> StillFrames(const std::string& sequence_dir) {
  std::set<long long> still;
  const std::string path = (std::filesystem::path(sequence_dir) / "objects.txt").string();
  std::error_code error;
  if (sequence_dir.empty() || !std::filesystem::is_regular_file(path, error)) return still;
  std::map<std::string, const ObjectPose*> previous;
  const std::vector<ObjectPose> poses = ReadObjectPoses(path);
  for (const ObjectPose& pose : poses) {
    const ObjectPose*& last = previous[pose.id];
    if (last != nullptr && pose.time > last->time) {
      const Eigen::Isometry3d step = last->world_from_object.inverse() * pose.world_from_object;
      if (step.translation().norm() < 0.001 &&
          Eigen::AngleAxisd(step.linear()).angle() < 0.1 * M_PI / 180.0) {
        still.insert(Microseconds(pose.time));
      }
    }
    last = &pose;
  }
  return still;
}

}  // namespace

MaskStage::MaskStage(const Camera& camera, const DynamicMaskOptions& options, bool enabled,
                     std::unique_ptr<Detector> detector, bool detector_in_background,
                     const std::string& sequence_dir, bool detector_thread)
    : enabled_(enabled), options_(options), truth_(sequence_dir) {
  if (!enabled_) return;
  if (truth_.available()) still_frames_us_ = StillFrames(sequence_dir);
  if (detector != nullptr && options_.semantics) {
    detections_ = std::make_unique<DetectionSchedule>(
        std::move(detector), options_.detector_interval, detector_in_background, detector_thread,
        options_.second_opinion_share);
    statistics_.detector_in_background = detector_in_background && detector_thread;
    semantics_ = true;
    detector_name_ = detections_->detector().name();
  }
  options_.flow.klt_window = ResolvedKltWindow(options_.flow.klt_window, detections_ != nullptr);
  options_.flow_points = ResolvedFlowPoints(options_.flow_points, detections_ != nullptr);
  options_.unclaimed_outline_min_px =
      ResolvedUnclaimedOutlineMinPx(options_.unclaimed_outline_min_px, detections_ != nullptr);
  // Only a detector with a second opinion needs the masker to say where to ask it.
  DynamicMaskOptions masker_options = options_;
  if (!detections_ || !detections_->detector().has_second_opinion()) {
    masker_options.second_opinion_share = 0.0;
  }
  masker_ = std::make_unique<DynamicMasker>(camera, masker_options);
}

cv::Mat MaskStage::Compute(const Frame& frame, const cv::Mat& gray, const FlowStep* flow,
                           const std::optional<Eigen::Isometry3d>& world_from_camera) {
  if (!enabled_) return cv::Mat();
  MaskingStatistics& s = statistics_;
  std::optional<DetectorRun> run;
  if (detections_) {
    run = detections_->Next(frame.color, flow, masker_->WantsSecondOpinion());
    s.detector_wait_ms = detections_->wait_ms();
    s.detector_runs = detections_->runs();
    s.second_opinion_runs = detections_->second_opinion_runs();
  }
  if (run) {
    s.detector_ms.push_back(run->ms);
    s.detector_cpu_ms += run->cpu_ms;
    for (const Detection& detection : run->detections) {
      ++s.detections_by_level[MotionLevelName(detection.level)];
    }
  }
  const double cpu = ThreadCpuMs();
  const DynamicMaskResult result = masker_->Compute(gray, frame.depth_m, world_from_camera,
                                                    run ? &run->detections : nullptr, flow);
  s.mask_cpu_ms += ThreadCpuMs() - cpu;
  ++s.frames;
  s.mask_ms.push_back(result.ms);
  s.share_sum += result.share;
  s.depth_seeds += static_cast<size_t>(result.depth_seeds);
  s.flow_seeds += static_cast<size_t>(result.flow_seeds);
  s.high_regions += static_cast<size_t>(result.high_regions);
  s.high_confirmed += static_cast<size_t>(result.high_confirmed);
  s.medium_moving += static_cast<size_t>(result.medium_moving);
  s.medium_static += static_cast<size_t>(result.medium_static);
  s.high_static += static_cast<size_t>(result.high_static);
  s.geometric_only += static_cast<size_t>(result.geometric_only_regions);
  s.geometric_outlined += static_cast<size_t>(result.geometric_outlined);
  s.frames_with_mask += result.share > 0.0 ? 1 : 0;
  if (truth_.available()) {
    const cv::Mat truth = truth_.Get(frame.time);
    if (!truth.empty() && truth.size() == result.mask.size()) {
      score_.Add(result.mask, truth);
      if (still_frames_us_.count(Microseconds(frame.time)) > 0 && cv::countNonZero(truth) > 0) {
        still_score_.Add(result.mask, truth);
      }
    }
  }
  return result.mask;
}

std::vector<FoundMoving> MaskStage::AddReference(const Frame& frame, const cv::Mat& mask,
                                                 const Eigen::Isometry3d& world_from_camera,
                                                 int keyframe_id) {
  if (!enabled_) return {};
  return masker_->AddReference(
      {frame.time, frame.depth_m, mask, world_from_camera, cv::Mat(), keyframe_id});
}

void MaskStage::Repose(const std::map<int, Eigen::Isometry3d>& world_from_keyframe) {
  if (enabled_) masker_->Repose(world_from_keyframe);
}

void MaskStage::EndFrames() {
  detections_.reset();
  if (masker_) masker_->ForgetReferences();
}

MaskingStatistics MaskStage::statistics() const {
  MaskingStatistics statistics = statistics_;
  if (score_.frames > 0 || score_.true_positive + score_.false_positive > 0) {
    statistics.score = score_;
  }
  if (still_score_.frames > 0) statistics.score_while_still = still_score_;
  return statistics;
}

}  // namespace stillmap
