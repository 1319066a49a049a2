#include "bag/bag_frames.h"

#include <algorithm>
#include <cstdio>
#include <numeric>

#include "stillmap/io/error.h"
#include "stillmap/io/file_list.h"

namespace stillmap {
namespace {

// Sorted by stamp (a bag is in record order, which stamps need not follow).
std::vector<size_t> ByStamp(const BagStream& stream) {
  std::vector<size_t> order(stream.stamps.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(),
                   [&](size_t a, size_t b) { return stream.stamps[a] < stream.stamps[b]; });
  return order;
}

}  // namespace

BagFrames::BagFrames(std::unique_ptr<BagReader> reader, const BagStream& color,
                     const BagStream& depth, double metres_per_unit)
    : reader_(std::move(reader)),
      color_topic_(color.name),
      depth_topic_(depth.name),
      color_kind_(color.kind),
      depth_kind_(depth.kind),
      metres_per_unit_(metres_per_unit) {}

void BagFrames::Pair(const BagStream& color, const BagStream& depth,
                     double max_pair_time_difference, std::vector<FrameEntry>* frames) {
  const std::vector<size_t> color_order = ByStamp(color), depth_order = ByStamp(depth);
  std::vector<double> color_times, depth_times;
  for (const size_t i : color_order) color_times.push_back(color.stamps[i]);
  for (const size_t i : depth_order) depth_times.push_back(depth.stamps[i]);
  for (const auto& [c, d] :
       AssociateTimestamps(color_times, depth_times, max_pair_time_difference)) {
    FrameEntry frame;
    frame.time = color_times[c];
    frame.depth_time = depth_times[d];
    frames->push_back(frame);
    color_positions_.push_back(color.positions[color_order[c]]);
    depth_positions_.push_back(depth.positions[depth_order[d]]);
  }
}

void BagFrames::Load(size_t index, double time, cv::Mat* color, cv::Mat* depth_m) const {
  char stamp[48];
  std::snprintf(stamp, sizeof(stamp), " at t = %.6f s", time);
  const BagSerialization serialization = reader_->serialization();
  const std::vector<std::uint8_t> color_bytes = reader_->Read(color_positions_.at(index));
  const std::string color_where = reader_->path() + ": " + color_topic_ + stamp;
  std::string error;
  if (color_kind_ == BagStreamKind::kImage) {
    RosImage image;
    if (!DecodeRosImage(color_bytes.data(), color_bytes.size(), serialization, &image, &error)) {
      throw InputError(color_where + ": " + error);
    }
    *color = ColorFromRosImage(image, color_where);
  } else {
    RosCompressedImage image;
    if (!DecodeRosCompressedImage(color_bytes.data(), color_bytes.size(), serialization, &image,
                                  &error)) {
      throw InputError(color_where + ": " + error);
    }
    *color = ColorFromRosCompressed(image, color_where);
  }
  const std::vector<std::uint8_t> depth_bytes = reader_->Read(depth_positions_.at(index));
  const std::string depth_where = reader_->path() + ": " + depth_topic_ + stamp;
  if (depth_kind_ == BagStreamKind::kImage) {
    RosImage image;
    if (!DecodeRosImage(depth_bytes.data(), depth_bytes.size(), serialization, &image, &error)) {
      throw InputError(depth_where + ": " + error);
    }
    *depth_m = DepthFromRosImage(image, metres_per_unit_, depth_where);
  } else {
    RosCompressedImage image;
    if (!DecodeRosCompressedImage(depth_bytes.data(), depth_bytes.size(), serialization, &image,
                                  &error)) {
      throw InputError(depth_where + ": " + error);
    }
    *depth_m = DepthFromRosCompressed(image, metres_per_unit_, depth_where);
  }
}

}  // namespace stillmap
