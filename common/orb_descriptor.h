// The 256-bit binary ORB descriptor and its Hamming distance.
//
// Byte i, bit j (LSB first) holds the result of the (8 i + j)-th BRIEF test,
// as OpenCV and ORB-SLAM2 lay it out; the DBoW2 text vocabulary lists the 32
// bytes b0 ... b31 in this order.
#pragma once

#include <bit>
#include <cstdint>
#include <cstring>

namespace rrslam {

struct alignas(32) OrbDescriptor {
  uint8_t bytes[32] = {};

  bool operator==(const OrbDescriptor& other) const {
    return std::memcmp(bytes, other.bytes, 32) == 0;
  }
  bool Bit(int i) const { return (bytes[i >> 3] >> (i & 7)) & 1; }
  void SetBit(int i, bool value) {
    if (value) bytes[i >> 3] |= uint8_t(1u << (i & 7));
    else bytes[i >> 3] &= uint8_t(~(1u << (i & 7)));
  }
};
static_assert(sizeof(OrbDescriptor) == 32);

// Number of differing bits, in [0, 256]: four 64-bit popcounts.
inline int HammingDistance(const OrbDescriptor& a, const OrbDescriptor& b) {
  uint64_t x[4], y[4];
  std::memcpy(x, a.bytes, 32);
  std::memcpy(y, b.bytes, 32);
  return std::popcount(x[0] ^ y[0]) + std::popcount(x[1] ^ y[1]) +
         std::popcount(x[2] ^ y[2]) + std::popcount(x[3] ^ y[3]);
}

}  // namespace rrslam
