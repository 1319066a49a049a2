// One 64-bit hash key per voxel index triple, 21 bits per axis (+-1e6 voxels): the mesh's voxels
// and corners, and the floor fit's thinned cloud.
#pragma once

#include <cstdint>

namespace stillmap {

inline std::int64_t VoxelKey(std::int64_t x, std::int64_t y, std::int64_t z) {
  constexpr std::int64_t kMask = (std::int64_t{1} << 21) - 1;
  return ((x & kMask) << 42) | ((y & kMask) << 21) | (z & kMask);
}

}  // namespace stillmap
