// RVL, the lossless depth codec of A. D. Wilson, "Fast Lossless Depth Image Compression" (ISS
// 2017), as compressed_depth_image_transport sends it ("16UC1; compressedDepth rvl"). Written by
// stillmap: no Debian package decodes RVL outside a ROS installation.
#pragma once

#include <cstddef>
#include <cstdint>

namespace stillmap {

// Decodes `size` bytes of RVL into `pixels` 16-bit values. False when the data ends early, runs
// past `pixels`, or leaves pixels undecoded; never reads or writes outside the two buffers.
bool DecodeRvl(const std::uint8_t* data, size_t size, std::uint16_t* out, size_t pixels);

}  // namespace stillmap
