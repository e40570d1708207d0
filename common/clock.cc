#include "common/clock.h"

#include <time.h>
#include <unistd.h>

#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>

namespace rrslam {
namespace {

// Seconds since boot at which this process started, or a negative value.
double StartSecondsSinceBoot() {
  std::ifstream in("/proc/self/stat");
  std::string stat;
  if (!std::getline(in, stat)) return -1;
  // Field 2 (comm) is in parentheses and may hold spaces: fields 3... follow
  // the last ')'. starttime is field 22, the 20th after it.
  const size_t close = stat.rfind(')');
  if (close == std::string::npos) return -1;
  std::istringstream fields(stat.substr(close + 1));
  std::string field;
  for (int i = 3; i <= 22; ++i) {
    if (!(fields >> field)) return -1;
  }
  const long ticks_per_second = sysconf(_SC_CLK_TCK);
  if (ticks_per_second <= 0) return -1;
  try {
    return std::stod(field) / static_cast<double>(ticks_per_second);
  } catch (const std::exception&) {
    return -1;
  }
}

SteadyClock::time_point ComputeProcessStart() {
  const SteadyClock::time_point now = SteadyClock::now();
  timespec boot{};
  const double start = StartSecondsSinceBoot();
  if (start < 0 || clock_gettime(CLOCK_BOOTTIME, &boot) != 0) return now;
  const double age_s = static_cast<double>(boot.tv_sec) + 1e-9 * boot.tv_nsec - start;
  if (age_s < 0) return now;
  return now -
         std::chrono::duration_cast<SteadyClock::duration>(std::chrono::duration<double>(age_s));
}

}  // namespace

SteadyClock::time_point ProcessStartTime() {
  static const SteadyClock::time_point start = ComputeProcessStart();
  return start;
}

}  // namespace rrslam
