#include "stillmap/mapping/mapper.h"

#include <chrono>

#include "stillmap/mapping/map_io.h"

namespace stillmap {
namespace {

double MillisecondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
      .count();
}

}  // namespace

void MapperOptions::Validate() const {
  back_projection.Validate();
  voxel.Validate();
  occupancy.Validate();
}

Mapper::Mapper(const Camera& camera, const MapperOptions& options)
    : options_(options), projector_(camera, options.back_projection), cloud_(options.voxel) {
  options_.Validate();
  if (options_.occupancy_enabled) occupancy_ = std::make_unique<OccupancyMap>(options_.occupancy);
}

Mapper::~Mapper() {
  if (occupancy_job_.valid()) occupancy_job_.wait();
}

void Mapper::Finish() {
  if (!occupancy_job_.valid()) return;
  const auto start = std::chrono::steady_clock::now();
  occupancy_job_.get();
  statistics_.occupancy_wait_ms += MillisecondsSince(start);
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
  auto start = std::chrono::steady_clock::now();
  scratch_.Clear();
  projector_.BackProject(frame.depth_m, frame.color, frame.mask,
                         frame.world_from_camera.cast<float>(), &scratch_);
  statistics_.back_projection_ms += MillisecondsSince(start);

  if (occupancy_) {
    Finish();  // the previous frame's insertion
    occupancy_points_ = scratch_.positions;
    const Eigen::Vector3f origin = frame.world_from_camera.translation().cast<float>();
    auto insert = [this, origin] {
      const auto job_start = std::chrono::steady_clock::now();
      occupancy_->InsertScan(occupancy_points_, origin);
      statistics_.occupancy_ms += MillisecondsSince(job_start);
    };
    if (options_.occupancy_in_background) {
      occupancy_job_ = std::async(std::launch::async, insert);
    } else {
      insert();
    }
  }

  start = std::chrono::steady_clock::now();
  cloud_.Insert(scratch_);
  statistics_.voxel_ms += MillisecondsSince(start);
  ++statistics_.frames;
  statistics_.points += scratch_.size();
}

void Mapper::WriteCloud(const std::string& ply_path, const std::string& pcd_path) const {
  WriteCloudFiles(ply_path, pcd_path, cloud_);
}

void Mapper::WriteOccupancy(const std::string& bt_path, const std::string& ot_path) {
  Finish();
  if (!occupancy_) return;
  occupancy_->WriteBinary(bt_path);
  occupancy_->WriteFull(ot_path);
}

}  // namespace stillmap
