#include "stillmap/mapping/mapper.h"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <stdexcept>

#include "stillmap/io/cloud_files.h"
#include "stillmap/io/cpu_usage.h"
#include "stillmap/io/error.h"
#include "stillmap/io/option_names.h"
#include "stillmap/io/timing.h"

namespace stillmap {
namespace {

// The grid's views keep the nearest reading of each 4 x 4 block: at 4 m two blocks lie 3 cm apart,
// finer than the unseen layers looked for, at a quarter of the cleaning views' memory.
constexpr int kGridViewBlock = 4;

}  // namespace

double MapperOptions::Extent() const {
  const double cloud = VoxelCloud::Extent(voxel.leaf_size);
  return occupancy.enabled ? std::min(cloud, OccupancyMap::Extent(occupancy.resolution)) : cloud;
}

void MapperOptions::Validate() const {
  back_projection.Validate();
  voxel.Validate();
  occupancy.Validate();
  cleaning.Validate();
  if (min_map_points < 1)
    throw InputError(fmt::format("{} must be at least 1", OptionKey(*this, min_map_points)));
}

Mapper::Mapper(const Camera& camera, const MapperOptions& options, bool keep_grid_views)
    : options_(options),
      keep_grid_views_(keep_grid_views),
      projector_(camera, options.back_projection),
      cloud_(options.voxel),
      camera_(camera),
      cameras_{camera} {
  options_.Validate();
  if (options_.occupancy.enabled) occupancy_ = std::make_unique<OccupancyMap>(options_.occupancy);
}

Mapper::~Mapper() {
  if (fusion_job_.valid()) fusion_job_.wait();
  if (occupancy_job_.valid()) occupancy_job_.wait();
}

void Mapper::WaitForFusion() {
  const auto start = std::chrono::steady_clock::now();
  if (fusion_job_.valid()) {
    try {
      fusion_job_.get();
    } catch (...) {
      if (occupancy_job_.valid()) occupancy_job_.wait();
      throw;
    }
  }
  WaitForOccupancy();
  statistics_.wait_ms += MillisecondsSince(start);
}

FinishedMap Mapper::Finish() {
  if (finished_) throw std::logic_error("Mapper::Finish called twice");
  if (fusion_job_.valid() || occupancy_job_.valid()) WaitForFusion();
  finished_ = true;
  if (earlier_) {
    earlier_->Overlay(*occupancy_, options_.occupancy.DecisiveLogOdds());
    occupancy_ = std::move(earlier_);
  }
  return FinishedMap{std::move(cloud_), std::move(occupancy_), statistics_, std::move(views_),
                     cameras_,          std::move(grid_views_)};
}

void Mapper::Reset() {
  if (finished_) throw std::logic_error("Mapper::Reset called after Finish");
  if (fusion_job_.valid() || occupancy_job_.valid()) WaitForFusion();
  cloud_.Clear();
  if (occupancy_) occupancy_ = std::make_unique<OccupancyMap>(options_.occupancy);
  earlier_.reset();
  session_ = 0;
  camera_ = cameras_.front();
  projector_ = DepthBackProjector(camera_, options_.back_projection);
  cameras_.resize(1);
  views_.clear();
  grid_views_.clear();
  voxel_bytes_ = cloud_.MemoryBytes();
  views_bytes_ = 0;
  insertions_ = 0;
  CountOccupancyBytes();
  statistics_.frames = 0;
  statistics_.rays_only_frames = 0;
  statistics_.points = 0;
  ++statistics_.refusions;
}

void Mapper::BeginLaterSession(const Camera& camera) {
  if (finished_) throw std::logic_error("Mapper::BeginLaterSession called after Finish");
  if (fusion_job_.valid() || occupancy_job_.valid()) WaitForFusion();
  ++session_;
  camera_ = camera;
  projector_ = DepthBackProjector(camera, options_.back_projection);
  cameras_.push_back(camera);
  if (!occupancy_) return;
  if (earlier_) {
    earlier_->Overlay(*occupancy_, options_.occupancy.DecisiveLogOdds());
  } else {
    earlier_ = std::move(occupancy_);
  }
  occupancy_ = std::make_unique<OccupancyMap>(options_.occupancy);
  insertions_ = 0;
  CountOccupancyBytes();
}

void Mapper::WaitForOccupancy() {
  if (occupancy_job_.valid()) occupancy_job_.get();
}

void Mapper::Integrate(const MapperFrame& frame) {
  if (finished_) throw std::logic_error("Mapper::Integrate called after Finish");
  if (frame.color.empty() && !frame.rays_only) {
    throw std::logic_error("Mapper::Integrate: a frame with points needs its colour image");
  }
  if (!options_.in_background) {
    Fuse(frame);
    return;
  }
  if (fusion_job_.valid()) {  // the previous frame's back-projection and voxels
    const auto start = std::chrono::steady_clock::now();
    fusion_job_.get();
    statistics_.wait_ms += MillisecondsSince(start);
  }
  fusion_job_ = std::async(std::launch::async, [this, frame] {
    const double cpu = ThreadCpuMs();
    Fuse(frame);
    AddBackgroundCpu(ThreadCpuMs() - cpu);
  });
}

void Mapper::CountOccupancyBytes() {
  if (insertions_++ % 16 != 0) return;
  size_t bytes = occupancy_ ? occupancy_->MemoryBytes() : 0;
  if (earlier_) bytes += earlier_->MemoryBytes();
  occupancy_bytes_ = bytes;
}

MapperMemory Mapper::memory() const { return {voxel_bytes_, occupancy_bytes_, views_bytes_}; }

void Mapper::AddBackgroundCpu(double ms) {
  const std::lock_guard<std::mutex> lock(cpu_mutex_);
  statistics_.background_cpu_ms += ms;
}

void Mapper::Fuse(const MapperFrame& frame) {
  if (frame.rays_only && !occupancy_) {  // its rays have nowhere to go
    ++statistics_.rays_only_frames;
    return;
  }
  auto start = std::chrono::steady_clock::now();
  scratch_.Clear();
  projector_.BackProject(frame.depth_m, frame.color, frame.mask,
                         frame.world_from_camera.cast<float>(), &scratch_);
  statistics_.back_projection_ms += MillisecondsSince(start);

  if (occupancy_) {
    start = std::chrono::steady_clock::now();
    WaitForOccupancy();  // the previous frame's insertion
    statistics_.occupancy_wait_ms += MillisecondsSince(start);
    occupancy_points_ = scratch_.positions;
    const Eigen::Vector3f origin = frame.world_from_camera.translation().cast<float>();
    auto insert = [this, origin] {
      const auto job_start = std::chrono::steady_clock::now();
      const double cpu = ThreadCpuMs();
      occupancy_->InsertScan(occupancy_points_, origin);
      CountOccupancyBytes();
      statistics_.occupancy_ms += MillisecondsSince(job_start);
      if (options_.in_background) AddBackgroundCpu(ThreadCpuMs() - cpu);
    };
    if (options_.in_background) {
      occupancy_job_ = std::async(std::launch::async, insert);
    } else {
      insert();
    }
  }

  if (options_.cleaning.clear_seen_through_views && !frame.rays_only) {
    views_.push_back(MakeKeyframeView(frame.depth_m, frame.mask, frame.world_from_camera));
    views_.back().session = session_;
    views_.back().camera = static_cast<int>(cameras_.size()) - 1;
    views_bytes_ += views_.back().MemoryBytes();
  }
  if (keep_grid_views_ && !frame.rays_only) {
    const cv::Mat& moving = frame.moving_mask.empty() ? frame.mask : frame.moving_mask;
    grid_views_.push_back(
        MakeKeyframeView(frame.depth_m, moving, frame.world_from_camera, kGridViewBlock));
    grid_views_.back().session = session_;
    grid_views_.back().camera = static_cast<int>(cameras_.size()) - 1;
    views_bytes_ += grid_views_.back().MemoryBytes();
  }
  if (frame.rays_only) {
    ++statistics_.rays_only_frames;
    return;
  }
  start = std::chrono::steady_clock::now();
  cloud_.Insert(scratch_);
  voxel_bytes_ = cloud_.MemoryBytes();
  statistics_.voxel_ms += MillisecondsSince(start);
  ++statistics_.frames;
  statistics_.points += scratch_.size();
}

MapCleaningResult FinishedMap::CleanCloud(const MapCleaningOptions& options) {
  return stillmap::CleanCloud(options, occupancy.get(), cameras, views, &cloud);
}

std::vector<VoxelPoint> FinishedMap::TakeCloudPoints() {
  views = {};
  grid_views = {};
  return cloud.TakePoints();
}

void FinishedMap::WriteCloud(const std::string& ply_path, const std::string& pcd_path) const {
  WriteCloudFiles(ply_path, pcd_path, cloud.Points(), cloud.leaf_size(), "the poses' frame");
}

void FinishedMap::WriteOccupancy(const std::string& bt_path, const std::string& ot_path) const {
  if (!occupancy) return;
  occupancy->WriteBinary(bt_path);
  occupancy->WriteFull(ot_path);
}

}  // namespace stillmap
