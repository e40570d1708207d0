// Fuzz-only: the property check of every fuzz target. A broken property is a
// finding, so it aborts like a crash (libFuzzer saves the input).
#pragma once

#include <cstdlib>

namespace rrslam::fuzz {

inline void Check(bool condition) {
  if (!condition) std::abort();
}

}  // namespace rrslam::fuzz
