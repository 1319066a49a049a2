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

namespace {

// One image message decoded as its kind says, then converted.
template <typename FromImage, typename FromCompressed>
cv::Mat DecodeImage(BagStreamKind kind, const std::vector<std::uint8_t>& bytes,
                    BagSerialization serialization, const std::string& where, FromImage from_image,
                    FromCompressed from_compressed) {
  std::string error;
  if (kind == BagStreamKind::kImage) {
    RosImage image;
    if (!DecodeRosImage(bytes.data(), bytes.size(), serialization, &image, &error)) {
      throw InputError(where + ": " + error);
    }
    return from_image(image);
  }
  RosCompressedImage image;
  if (!DecodeRosCompressedImage(bytes.data(), bytes.size(), serialization, &image, &error)) {
    throw InputError(where + ": " + error);
  }
  return from_compressed(image);
}

}  // namespace

void BagFrames::Load(size_t index, double time, cv::Mat* color, cv::Mat* depth_m) const {
  char stamp[48];
  std::snprintf(stamp, sizeof(stamp), " at t = %.6f s", time);
  const BagSerialization serialization = reader_->serialization();
  const std::string color_where = reader_->path() + ": " + color_topic_ + stamp;
  *color = DecodeImage(
      color_kind_, reader_->Read(color_positions_.at(index)), serialization, color_where,
      [&](const RosImage& image) { return ColorFromRosImage(image, color_where); },
      [&](const RosCompressedImage& image) { return ColorFromRosCompressed(image, color_where); });
  const std::string depth_where = reader_->path() + ": " + depth_topic_ + stamp;
  *depth_m = DecodeImage(
      depth_kind_, reader_->Read(depth_positions_.at(index)), serialization, depth_where,
      [&](const RosImage& image) {
        return DepthFromRosImage(image, metres_per_unit_, depth_where);
      },
      [&](const RosCompressedImage& image) {
        return DepthFromRosCompressed(image, metres_per_unit_, depth_where);
      });
  if (registration_ != nullptr) *depth_m = registration_->Register(*depth_m, depth_where);
}

}  // namespace stillmap
