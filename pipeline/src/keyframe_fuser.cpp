#include "keyframe_fuser.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <opencv2/imgcodecs.hpp>
#include <utility>

#include "stillmap/io/timing.h"

namespace stillmap {
namespace {

// The revisit rule as the fuser applies it: with the selection off every keyframe is fused.
RevisitOptions RevisitsOf(const KeyframeSelectionOptions& selection) {
  RevisitOptions revisit = selection.revisit;
  if (!selection.enabled) revisit.max_seen_share = revisit.segment_max_seen_share = 1.0;
  return revisit;
}

std::vector<unsigned char> EncodePng(const cv::Mat& image) {
  std::vector<unsigned char> bytes;
  cv::imencode(".png", image, bytes, {cv::IMWRITE_PNG_COMPRESSION, 1});
  return bytes;
}

}  // namespace

KeyframeFuser::KeyframeFuser(const Camera& camera, const FuserOptions& options,
                             const MaskStage& masks, Mapper* mapper)
    : mapper_(*mapper),
      keep_for_refusion_(options.keep_for_refusion),
      keep_for_session_(options.keep_for_session),
      // The stored depth's step: the range the back-projection uses in 60000 steps (0.07 mm at
      // 4 m), far below any sensor's noise.
      depth_unit_m_(options.max_depth_m / 60000.0),
      parked_(std::make_shared<SpillFile>("the fused keyframes' compact copies")),
      selector_(options.selection),
      revisits_(camera, RevisitsOf(options.selection), options.min_depth_m, options.max_depth_m),
      factors_(camera) {
  judge_segments_ = RevisitsOf(options.selection).segment_max_seen_share < 1.0;
  if (masks.enabled() && options.recheck && options.masking.depth_check) {
    recheck_.emplace(masks.masker()->geometry(), options.masking);
  }
}

void KeyframeFuser::Hold(int keyframe_id, Frame frame, const cv::Mat& mask,
                         const Eigen::Isometry3d& world_from_camera) {
  MaskReference reference{frame.time, frame.depth_m, mask, world_from_camera, cv::Mat()};
  waiting_.emplace(keyframe_id, Waiting{std::move(frame), std::move(reference)});
}

cv::Mat KeyframeFuser::Recheck(const FinalKeyframe& keyframe, std::map<int, Waiting>::iterator it,
                               bool* changed) {
  std::vector<MaskReference*> later;
  for (auto next = std::next(it); next != waiting_.end(); ++next) {
    later.push_back(&next->second.reference);
  }
  const Waiting& waiting = it->second;
  return recheck_->Recheck(keyframe.time, waiting.frame.depth_m, keyframe.world_from_camera,
                           waiting.reference.mask, later, changed);
}

void KeyframeFuser::Fuse(const std::vector<FinalKeyframe>& finals,
                         const DepthCorrection& correction,
                         const std::function<bool(int keyframe_id)>& in_map,
                         const std::function<int(int keyframe_id)>& segment_of) {
  const auto start = std::chrono::steady_clock::now();
  for (const FinalKeyframe& keyframe : finals) {
    const auto it = waiting_.find(keyframe.id);
    if (it == waiting_.end()) continue;
    if (keyframe.culled) {  // keyframes kept before it saw its view: the map has the place
      waiting_.erase(it);
      continue;
    }
    const Frame& frame = it->second.frame;
    bool changed = false;
    const cv::Mat mask = recheck_ ? Recheck(keyframe, it, &changed) : it->second.reference.mask;
    recheck_additions_ += changed ? 1 : 0;
    const double share = mask.empty() ? 0.0
                                      : static_cast<double>(cv::countNonZero(mask)) /
                                            static_cast<double>(mask.total());
    if (selector_.Judge(share, keyframe.landmarks) == KeyframeVerdict::kFused) {
      MapperFrame input{frame.time, frame.color, frame.depth_m, mask, keyframe.world_from_camera,
                        false,      cv::Mat()};
      // The depth corrected as the tracker's self-calibration has it now (the poses are
      // consistent with it).
      if (!correction.IsIdentity()) input.depth_m = frame.depth_m.mul(factors_.For(correction));
      const int segment = segment_of ? segment_of(keyframe.id) : 0;
      if (in_map && !in_map(keyframe.id)) {
        Store(keyframe, input, cv::Mat(), segment, true);
      } else {
        FuseNow(keyframe, std::move(input), segment);
      }
    }
    if (recheck_) {
      MaskReference done = std::move(it->second.reference);
      done.mask = mask;
      done.world_from_camera = keyframe.world_from_camera;  // final
      recheck_->Remember(std::move(done), changed);
    }
    waiting_.erase(it);
  }
  fuse_ms_ += MillisecondsSince(start);
}

void KeyframeFuser::FuseNow(const FinalKeyframe& keyframe, MapperFrame input, int segment) {
  size_t cells = 0;
  const std::optional<cv::Mat> seen = Revisit(keyframe.id, input, &cells);
  if (!seen) return;
  if (KeepsEveryFused()) {
    Stored& stored = Store(keyframe, input, *seen, segment);
    stored.in_map = FusingLive();
    stored.cells_left_out = cells;
  }
  if (!seen->empty()) {
    input.moving_mask = input.mask.empty() ? cv::Mat::zeros(seen->size(), CV_8UC1) : input.mask;
    input.mask = input.mask.empty() ? *seen : (input.mask | *seen);
  }
  if (FusingLive()) mapper_.Integrate(input);
  fused_poses_.push_back({keyframe.time, keyframe.world_from_camera});
}

size_t KeyframeFuser::FuseJoined(const std::function<bool(int keyframe_id)>& in_map,
                                 const std::map<int, Eigen::Isometry3d>& world_from_keyframe) {
  size_t joined = 0;
  std::vector<Stored> kept;
  kept.reserve(stored_.size());
  for (Stored& stored : stored_) {
    if (stored.apart && in_map(stored.keyframe_id)) {
      const auto it = world_from_keyframe.find(stored.keyframe_id);
      if (it != world_from_keyframe.end()) stored.world_from_camera = it->second;
      if (!FuseStored(&stored)) continue;  // redundant: its segment's place was seen before
      ++joined;
    }
    kept.push_back(std::move(stored));
  }
  stored_ = std::move(kept);
  std::sort(fused_poses_.begin(), fused_poses_.end(),
            [](const StampedPose& a, const StampedPose& b) { return a.time < b.time; });
  return joined;
}

bool KeyframeFuser::FuseStored(Stored* stored) {
  MapperFrame input = Decode(*stored);  // moving pixels are 0 in its depth
  const std::optional<cv::Mat> seen = Revisit(stored->keyframe_id, input, &stored->cells_left_out);
  if (!seen) return false;
  if (!seen->empty()) {
    stored->seen_png = parked_->Append(EncodePng(*seen));
    input.moving_mask = cv::Mat::zeros(seen->size(), CV_8UC1);  // moving pixels: 0 in its depth
    input.mask = *seen;
  }
  stored->in_map = FusingLive();
  if (stored->in_map) mapper_.Integrate(input);
  fused_poses_.push_back({stored->time, stored->world_from_camera});
  stored->apart = false;
  return true;
}

SessionKeyframeList KeyframeFuser::TakeApart(const std::function<bool(int keyframe_id)>& take) {
  SessionKeyframeList out(parked_);
  std::vector<Stored> kept;
  for (Stored& stored : stored_) {
    if (stored.apart && take(stored.keyframe_id)) {
      AddTo(stored, &out);
    } else {
      kept.push_back(std::move(stored));
    }
  }
  stored_ = std::move(kept);
  return out;
}

MapperFrame KeyframeFuser::Decode(const Stored& stored, cv::Mat depth_m) const {
  MapperFrame input;
  input.time = stored.time;
  input.color = cv::imdecode(parked_->Read(stored.color_jpeg), cv::IMREAD_COLOR);
  input.depth_m = depth_m.empty() ? DepthOf(stored) : std::move(depth_m);
  if (stored.seen_png.size > 0) {
    input.mask = cv::imdecode(parked_->Read(stored.seen_png), cv::IMREAD_UNCHANGED);
    // Its moving pixels are 0 in its depth: the cells fused before are the whole mask.
    input.moving_mask = cv::Mat::zeros(input.mask.size(), CV_8UC1);
  }
  input.world_from_camera = stored.world_from_camera;
  return input;
}

MapperFrame KeyframeFuser::RaysOf(const Stored& stored, cv::Mat depth_m) {
  MapperFrame input;
  input.time = stored.time;
  input.depth_m = std::move(depth_m);
  input.world_from_camera = stored.world_from_camera;
  input.rays_only = true;
  return input;
}

std::vector<KeyframeFuser::KeptKeyframe> KeyframeFuser::KeptKeyframes() const {
  std::vector<KeptKeyframe> kept;
  kept.reserve(stored_.size());
  for (const Stored& stored : stored_) {
    kept.push_back({stored.keyframe_id, stored.time, stored.apart, stored.world_from_camera});
  }
  return kept;
}

void KeyframeFuser::ImagesOf(size_t index, cv::Mat* gray, cv::Mat* depth_m) const {
  const Stored& stored = stored_.at(index);
  *gray = cv::imdecode(parked_->Read(stored.color_jpeg), cv::IMREAD_GRAYSCALE);
  *depth_m = DepthOf(stored);
}

cv::Mat KeyframeFuser::DepthOf(const Stored& stored) const {
  cv::Mat depth_m;
  cv::imdecode(parked_->Read(stored.depth_png), cv::IMREAD_UNCHANGED)
      .convertTo(depth_m, CV_32F, depth_unit_m_);
  return depth_m;
}

std::optional<cv::Mat> KeyframeFuser::Revisit(int keyframe_id, const MapperFrame& input,
                                              size_t* cells_left_out) {
  const size_t before = revisits_.cells_left_out();
  std::optional<cv::Mat> seen = revisits_.Admit(
      revisits_.MakeView(keyframe_id, input.depth_m, input.mask, input.world_from_camera));
  seen_before_ += seen ? 0 : 1;
  *cells_left_out = seen ? revisits_.cells_left_out() - before : 0;
  cells_left_out_ += *cells_left_out;
  return seen;
}

KeyframeFuser::Stored& KeyframeFuser::Store(const FinalKeyframe& keyframe, const MapperFrame& input,
                                            const cv::Mat& seen, int segment, bool apart) {
  Stored stored;
  stored.keyframe_id = keyframe.id;
  stored.segment = segment;
  stored.time = input.time;
  stored.world_from_camera = input.world_from_camera;
  stored.apart = apart;
  cv::Mat depth;
  input.depth_m.convertTo(depth, CV_16U, 1.0 / depth_unit_m_);  // saturates beyond the range
  if (!input.mask.empty()) depth.setTo(0, input.mask);
  stored.depth_png = parked_->Append(EncodePng(depth));
  if (!seen.empty()) stored.seen_png = parked_->Append(EncodePng(seen));
  std::vector<unsigned char> bytes;
  cv::imencode(".jpg", input.color, bytes, {cv::IMWRITE_JPEG_QUALITY, 95});
  stored.color_jpeg = parked_->Append(bytes);
  if (keep_for_session_ || apart) {
    bytes.clear();
    AppendSessionFeatures(SessionFeatures(keyframe.features), &bytes);
    stored.features = parked_->Append(bytes);
    stored.feature_count = keyframe.features.size();
  }
  stored_.push_back(stored);
  return stored_.back();
}

SessionKeyframeList KeyframeFuser::TakeSessionKeyframes() {
  SessionKeyframeList out(parked_);
  if (!keep_for_session_) return out;
  for (const Stored& stored : stored_) {
    if (!stored.apart && !stored.rays_only) AddTo(stored, &out);
  }
  stored_.clear();
  return out;
}

void KeyframeFuser::AddTo(const Stored& stored, SessionKeyframeList* list) {
  SessionKeyframe keyframe;
  keyframe.id = stored.keyframe_id;
  keyframe.time = stored.time;
  keyframe.map_from_camera = stored.world_from_camera;
  list->AddParked(std::move(keyframe), stored.feature_count, stored.features, stored.depth_png,
                  stored.color_jpeg);
}

size_t KeyframeFuser::stored_bytes() const { return stored_.capacity() * sizeof(Stored); }

size_t KeyframeFuser::Refuse(const std::map<int, Eigen::Isometry3d>& world_from_keyframe) {
  const auto start = std::chrono::steady_clock::now();
  size_t moved = 0;
  for (Stored& stored : stored_) {
    const auto it = world_from_keyframe.find(stored.keyframe_id);
    if (it == world_from_keyframe.end()) continue;
    if (!stored.apart && Moved(stored, it->second)) ++moved;
    stored.world_from_camera = it->second;
  }
  revisits_.Repose(world_from_keyframe);
  // Nothing moved: only the keyframes kept since NoteNewSegment are fused, in the order they
  // came (the order live fusion has); else the map is fused again from the start.
  const bool again = moved > 0 || refusion_due_;
  if (again) {
    mapper_.Reset();
    fused_poses_.clear();
  }
  if (judge_segments_) {
    const auto waits = [again](const Stored& stored) {
      return !stored.apart && (again || !stored.in_map);
    };
    if (std::any_of(stored_.begin(), stored_.end(), waits)) FuseAtFinalPoses(again);
  } else {
    for (Stored& stored : stored_) {
      if (stored.apart || (stored.in_map && !again)) continue;
      mapper_.Integrate(Decode(stored));
      stored.in_map = true;
      if (again) fused_poses_.push_back({stored.time, stored.world_from_camera});
    }
  }
  refusion_due_ = false;
  deferring_ = false;
  refuse_ms_ += MillisecondsSince(start);
  return moved;
}

void KeyframeFuser::FuseAtFinalPoses(bool again) {
  // The views judged at fusion time lay where the poses were then: every view is made again at
  // its final pose, in fusion order, for the keyframes fused here to be judged against. Only
  // whether a keyframe is fused at all is decided here; the cells it leaves out stay those judged
  // when it came (judged again at the final poses, floor seed 2's map lost 0.7 points within 3 cm
  // and floor_lost's 0.7 of completeness: docs/figures.md). A redundant keyframe's rays still go
  // into the map, not its points: they clear what moved away since (without them the rule
  // doubled floor seed 2's ghosts).
  revisits_.Forget();
  const std::map<int, double> path_m = PathsAlongSegments();
  std::vector<double> dropped;
  for (Stored& stored : stored_) {
    if (stored.apart) continue;
    // Moving pixels are 0 in the kept depth, read once for the view and the mapper.
    cv::Mat depth_m = DepthOf(stored);
    CellView view = revisits_.MakeView(stored.keyframe_id, depth_m, cv::Mat(),
                                       stored.world_from_camera, stored.segment);
    view.path_m = path_m.at(stored.keyframe_id);
    if (stored.in_map && !again) {  // in the map before, where it still is
      if (!stored.rays_only) revisits_.Remember(std::move(view));
      continue;
    }
    const bool redundant = !revisits_.AdmitAcrossSegments(std::move(view));
    SetRedundant(&stored, redundant);
    if (redundant) {
      dropped.push_back(stored.time);
    } else if (again) {
      fused_poses_.push_back({stored.time, stored.world_from_camera});
    }
    mapper_.Integrate(redundant ? RaysOf(stored, std::move(depth_m))
                                : Decode(stored, std::move(depth_m)));
    stored.in_map = true;
  }
  revisits_.Forget();
  const auto is_dropped = [&dropped](const StampedPose& pose) {
    return std::find(dropped.begin(), dropped.end(), pose.time) != dropped.end();
  };
  fused_poses_.erase(std::remove_if(fused_poses_.begin(), fused_poses_.end(), is_dropped),
                     fused_poses_.end());
}

void KeyframeFuser::SetRedundant(Stored* stored, bool redundant) {
  if (stored->rays_only == redundant) return;
  if (redundant) {
    cells_left_out_ -= stored->cells_left_out;
    ++seen_before_;
  } else {
    cells_left_out_ += stored->cells_left_out;
    --seen_before_;
  }
  stored->rays_only = redundant;
}

std::map<int, double> KeyframeFuser::PathsAlongSegments() const {
  // Keyframe ids follow time: each segment's keyframes by id trace its camera's path.
  std::map<int, const Stored*> by_id;
  for (const Stored& stored : stored_) by_id[stored.keyframe_id] = &stored;
  std::map<int, std::pair<double, Eigen::Vector3d>> walked;  // by segment: path, last position
  std::map<int, double> path_m;
  for (const auto& [id, stored] : by_id) {
    const Eigen::Vector3d position = stored->world_from_camera.translation();
    const auto [it, first] = walked.try_emplace(stored->segment, 0.0, position);
    if (!first) {
      it->second.first += (position - it->second.second).norm();
      it->second.second = position;
    }
    path_m[id] = it->second.first;
  }
  return path_m;
}

void KeyframeFuser::NoteCorrections(const std::map<int, Eigen::Isometry3d>& world_from_keyframe) {
  if (refusion_due_ || !KeepsEveryFused()) return;
  const bool moved = std::any_of(stored_.begin(), stored_.end(), [&](const Stored& stored) {
    const auto it = world_from_keyframe.find(stored.keyframe_id);
    return stored.in_map && it != world_from_keyframe.end() && Moved(stored, it->second);
  });
  if (!moved) return;
  refusion_due_ = true;
  mapper_.Reset();
  for (Stored& stored : stored_) stored.in_map = false;
}

void KeyframeFuser::NoteNewSegment() {
  if (KeepsEveryFused()) deferring_ = true;
}

void KeyframeFuser::EndKeyframes() {
  recheck_.reset();
  revisits_.Forget();
}

bool KeyframeFuser::Moved(const Stored& stored, const Eigen::Isometry3d& world_from_camera) {
  const Eigen::Isometry3d change = stored.world_from_camera.inverse() * world_from_camera;
  return change.translation().norm() > 0.001 || RotationAngleDeg(change) > 0.05;
}

size_t KeyframeFuser::held_bytes() const {
  size_t bytes = 0;
  for (const auto& [id, waiting] : waiting_) {
    // The reference shares the frame's depth.
    for (const cv::Mat* image :
         {&waiting.frame.color, &waiting.frame.depth_m, &waiting.reference.mask}) {
      bytes += image->total() * image->elemSize();
    }
  }
  return bytes;
}

SelectionFigures KeyframeFuser::figures() const {
  return {selector_.invalid(), selector_.redundant(), seen_before_, recheck_additions_,
          cells_left_out_};
}

}  // namespace stillmap
