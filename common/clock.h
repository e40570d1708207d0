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

// When this process started (exec, before the dynamic loader and static
// initialization), on the steady clock: now minus the process's age, from
// the kernel's start time in /proc/self/stat. Resolution one clock tick
// (sysconf(_SC_CLK_TCK), 10 ms on Linux). Falls back to the first call's
// time when /proc cannot be read. Thread-safe.
SteadyClock::time_point ProcessStartTime();

}  // namespace rrslam
