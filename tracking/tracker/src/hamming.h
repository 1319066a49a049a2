// The Hamming distance of two 256-bit ORB descriptors, each as four 64-bit words.
#pragma once

#include <array>
#include <cstdint>

namespace stillmap {

using Descriptor = std::array<std::uint64_t, 4>;

// Set bits of one word. Without -mpopcnt (Debian's baseline x86-64), __builtin_popcountll is a
// call into libgcc's table loop, which perf showed at 0.8 % of a whole build: the bit-parallel
// count below is branch-free and inlined.
inline int PopCount64(std::uint64_t x) {
#if defined(__POPCNT__) || !defined(__x86_64__)
  return __builtin_popcountll(x);
#else
  x -= (x >> 1) & 0x5555555555555555ULL;
  x = (x & 0x3333333333333333ULL) + ((x >> 2) & 0x3333333333333333ULL);
  x = (x + (x >> 4)) & 0x0F0F0F0F0F0F0F0FULL;
  return static_cast<int>((x * 0x0101010101010101ULL) >> 56);
#endif
}

inline int HammingDistance(const Descriptor& a, const Descriptor& b) {
  return PopCount64(a[0] ^ b[0]) + PopCount64(a[1] ^ b[1]) + PopCount64(a[2] ^ b[2]) +
         PopCount64(a[3] ^ b[3]);
}

}  // namespace stillmap
