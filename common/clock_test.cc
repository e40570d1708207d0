#include "common/clock.h"

#include <gtest/gtest.h>

namespace rrslam {
namespace {

TEST(Clock, ProcessStartIsBeforeNowAndStable) {
  const SteadyClock::time_point start = ProcessStartTime();
  const double age_ms = MillisecondsSince(start);
  EXPECT_GE(age_ms, 0.0);
  // The test binary started minutes ago at most.
  EXPECT_LT(age_ms, 10 * 60 * 1000.0);
  EXPECT_EQ(ProcessStartTime(), start);
}

}  // namespace
}  // namespace rrslam
