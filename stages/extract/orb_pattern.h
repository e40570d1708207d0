// The sampling pattern of the rotated BRIEF descriptor (ORB): 256 point pairs
// inside a 31x31 patch centred on the keypoint.
#pragma once

#include <cstdint>

namespace rrslam {

inline constexpr int kOrbPatternTests = 256;

// Row i = {x1, y1, x2, y2}, pixel offsets from the keypoint in [-13, 12] (x
// right, y down) before rotation by the keypoint angle. Bit i of a descriptor
// is I(x1, y1) < I(x2, y2) on the smoothed image (see orb_descriptor.h for the
// bit layout).
extern const int8_t kOrbPattern[kOrbPatternTests][4];

}  // namespace rrslam
