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
    if (value)
      bytes[i >> 3] |= uint8_t(1u << (i & 7));
    else
      bytes[i >> 3] &= uint8_t(~(1u << (i & 7)));
  }
};
static_assert(sizeof(OrbDescriptor) == 32);

// A descriptor held as four 64-bit words, for inner loops that compare one
// descriptor against many (loaded once, kept in registers).
struct DescriptorWords {
  uint64_t w[4];
};

inline DescriptorWords ToWords(const OrbDescriptor& d) {
  DescriptorWords x;
  std::memcpy(x.w, d.bytes, 32);
  return x;
}

// Number of differing bits, in [0, 256]: four 64-bit popcounts.
inline int HammingDistance(const DescriptorWords& a, const DescriptorWords& b) {
  return std::popcount(a.w[0] ^ b.w[0]) + std::popcount(a.w[1] ^ b.w[1]) +
         std::popcount(a.w[2] ^ b.w[2]) + std::popcount(a.w[3] ^ b.w[3]);
}

inline int HammingDistance(const OrbDescriptor& a, const OrbDescriptor& b) {
  return HammingDistance(ToWords(a), ToWords(b));
}

}  // namespace rrslam
