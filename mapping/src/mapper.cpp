#include "stillmap/mapping/mapper.h"

#include <algorithm>
#include <chrono>

#include "stillmap/mapping/map_io.h"

namespace stillmap {
namespace {

double MillisecondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
      .count();
}

}  // namespace

double MapperOptions::Extent() const {
  const double cloud = VoxelCloud::Extent(voxel.leaf_size);
  return occupancy_enabled ? std::min(cloud, OccupancyMap::Extent(occupancy.resolution)) : cloud;
}

void MapperOptions::Validate() const {
  back_projection.Validate();
  voxel.Validate();
  occupancy.Validate();
  cleaning.Validate();
}

Mapper::Mapper(const Camera& camera, const MapperOptions& options)
    : options_(options),
      projector_(camera, options.back_projection),
      cloud_(options.voxel),
      camera_(camera) {
  options_.Validate();
  if (options_.occupancy_enabled) occupancy_ = std::make_unique<OccupancyMap>(options_.occupancy);
}

Mapper::~Mapper() {
  if (fusion_job_.valid()) fusion_job_.wait();
  if (occupancy_job_.valid()) occupancy_job_.wait();
}

void Mapper::Finish() {
  // Nothing pending: returns without writing anything, so that callers on several threads may
  // use the finished maps together (the pipeline cleans the cloud while the OctoMap is written).
  if (!fusion_job_.valid() && !occupancy_job_.valid()) return;
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

void Mapper::WaitForOccupancy() {
  if (occupancy_job_.valid()) occupancy_job_.get();
}

const VoxelCloud& Mapper::cloud() {
  Finish();
  return cloud_;
}

const OccupancyMap* Mapper::occupancy() {
  Finish();
  return occupancy_.get();
}

const MapperStatistics& Mapper::statistics() {
  Finish();
  return statistics_;
}

void Mapper::Integrate(const MapperFrame& frame) {
  if (!options_.in_background) {
    Fuse(frame);
    return;
  }
  if (fusion_job_.valid()) {  // the previous frame's back-projection and voxels
    const auto start = std::chrono::steady_clock::now();
    fusion_job_.get();
    statistics_.wait_ms += MillisecondsSince(start);
  }
  fusion_job_ = std::async(std::launch::async, [this, frame] { Fuse(frame); });
}

void Mapper::Fuse(const MapperFrame& frame) {
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
      occupancy_->InsertScan(occupancy_points_, origin);
      statistics_.occupancy_ms += MillisecondsSince(job_start);
    };
    if (options_.in_background) {
      occupancy_job_ = std::async(std::launch::async, insert);
    } else {
      insert();
    }
  }

  if (options_.cleaning.clear_seen_through_views) {
    views_.push_back(MakeKeyframeView(frame.depth_m, frame.mask, frame.world_from_camera));
  }
  start = std::chrono::steady_clock::now();
  cloud_.Insert(scratch_);
  statistics_.voxel_ms += MillisecondsSince(start);
  ++statistics_.frames;
  statistics_.points += scratch_.size();
}

MapCleaningResult Mapper::CleanCloud() {
  Finish();
  return stillmap::CleanCloud(options_.cleaning, occupancy_.get(), camera_, views_, &cloud_);
}

void Mapper::WriteCloud(const std::string& ply_path, const std::string& pcd_path) {
  Finish();
  WriteCloudFiles(ply_path, pcd_path, cloud_);
}

void Mapper::WriteOccupancy(const std::string& bt_path, const std::string& ot_path) {
  Finish();
  if (!occupancy_) return;
  occupancy_->WriteBinary(bt_path);
  occupancy_->WriteFull(ot_path);
}

}  // namespace stillmap
