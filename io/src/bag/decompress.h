// The block compressions of recorded bags, through Debian's libraries: bz2 (libbz2), lz4 frames
// (liblz4; ROS 1's roslz4 and MCAP write the standard frame format) and zstd (libzstd). Each
// decompresses a whole block whose uncompressed size the container states, and refuses anything
// else.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace stillmap {

// Decompresses `size` bytes of `compression` ("none" or "", "bz2", "lz4", "zstd") into exactly
// `uncompressed_size` bytes of *out. False with *error set for an unknown compression, damaged
// data or another size.
bool DecompressBlock(const std::string& compression, const std::uint8_t* data, size_t size,
                     size_t uncompressed_size, std::vector<std::uint8_t>* out, std::string* error);

}  // namespace stillmap
