#include "common/task_thread.h"

#include <gtest/gtest.h>

#include <stdexcept>
#include <thread>
#include <vector>

namespace rrslam {
namespace {

TEST(TaskThread, RunsEachTaskOnItsOwnThreadInStep) {
  TaskThread worker;
  std::vector<int> order;
  std::thread::id first;
  for (int i = 0; i < 100; ++i) {
    worker.Run([&, i] {
      if (i == 0) first = std::this_thread::get_id();
      EXPECT_EQ(std::this_thread::get_id(), first);  // Always the same thread...
      order.push_back(i);
    });
    ASSERT_EQ(order.size(), static_cast<size_t>(i + 1));  // ...finished when Run returns.
  }
  EXPECT_NE(first, std::this_thread::get_id());  // ...not the caller.
  for (int i = 0; i < 100; ++i) EXPECT_EQ(order[i], i);
}

TEST(TaskThread, RethrowsWhatATaskThrowsAndRunsTheNext) {
  TaskThread worker;
  EXPECT_THROW(worker.Run([] { throw std::runtime_error("bad"); }), std::runtime_error);
  bool ran = false;
  worker.Run([&] { ran = true; });  // No stale error from the task before.
  EXPECT_TRUE(ran);
}

TEST(TaskThread, StopsWithoutATask) {
  TaskThread worker;  // The destructor joins a thread that never ran anything.
}

}  // namespace
}  // namespace rrslam
