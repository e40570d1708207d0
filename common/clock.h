// Wall-clock durations for timings (run reports, benchmarks): steady_clock,
// in milliseconds.
#pragma once

#include <chrono>

namespace rrslam {

using SteadyClock = std::chrono::steady_clock;

// Milliseconds from `start` to now.
inline double MillisecondsSince(SteadyClock::time_point start) {
  return std::chrono::duration<double, std::milli>(SteadyClock::now() - start).count();
}

}  // namespace rrslam
