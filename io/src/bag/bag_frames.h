// A bag's colour/depth pairs, decoded on demand from where the scan found them.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "bag/bag_streams.h"
#include "bag/depth_registration.h"
#include "stillmap/io/sequence.h"

namespace stillmap {

class BagFrames {
 public:
  BagFrames(std::unique_ptr<BagReader> reader, const BagStream& color, const BagStream& depth,
            double metres_per_unit);
  // Pairs the streams by header stamp within max_pair_time_difference (TUM's associate.py);
  // fills *frames (no paths) and keeps each pair's positions.
  void Pair(const BagStream& color, const BagStream& depth, double max_pair_time_difference,
            std::vector<FrameEntry>* frames);
  // Depth from a camera of its own: registered into colour as each pair is loaded.
  void RegisterDepth(std::unique_ptr<DepthRegistration> registration) {
    registration_ = std::move(registration);
  }
  // Decodes pair `index` (colour BGR, depth in metres, registered when RegisterDepth was called).
  // Throws InputError naming the bag, the topic and the stamp for a message that does not decode.
  void Load(size_t index, double time, cv::Mat* color, cv::Mat* depth_m) const;

 private:
  std::unique_ptr<BagReader> reader_;
  std::string color_topic_, depth_topic_;
  BagStreamKind color_kind_, depth_kind_;
  double metres_per_unit_;
  std::vector<BagPosition> color_positions_, depth_positions_;  // per pair
  std::unique_ptr<DepthRegistration> registration_;
};

}  // namespace stillmap
