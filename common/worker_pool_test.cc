#include "common/worker_pool.h"

#include <gtest/gtest.h>

#include <atomic>
#include <stdexcept>
#include <vector>

namespace rrslam {
namespace {

TEST(WorkerPool, RunsEveryIndexOnceOverManyLoops) {
  for (int threads : {1, 2, 4}) {
    WorkerPool pool(threads);
    EXPECT_EQ(pool.size(), threads);
    for (size_t n : {0u, 1u, 7u, 1000u}) {
      std::vector<std::atomic<int>> hits(n);
      pool.ParallelFor(n, [&](size_t i) { hits[i].fetch_add(1); });
      for (size_t i = 0; i < n; ++i) EXPECT_EQ(hits[i].load(), 1) << threads << " " << i;
    }
  }
}

TEST(WorkerPool, AnIndexMayWaitForASmallerOne) {
  // Index 0 publishes; the others wait for it. Claiming in increasing order
  // guarantees index 0 has started, so this cannot deadlock.
  WorkerPool pool(3);
  for (int round = 0; round < 50; ++round) {
    std::atomic<int> ready{0};
    std::atomic<int> seen{0};
    pool.ParallelFor(8, [&](size_t i) {
      if (i == 0) {
        ready.store(1);
        ready.notify_all();
        return;
      }
      ready.wait(0);
      seen.fetch_add(1);
    });
    EXPECT_EQ(seen.load(), 7);
  }
}

TEST(WorkerPool, RethrowsAfterEveryIndexWasTried) {
  WorkerPool pool(2);
  std::atomic<int> ran{0};
  EXPECT_THROW(pool.ParallelFor(100,
                                [&](size_t i) {
                                  ran.fetch_add(1);
                                  if (i == 3) throw std::runtime_error("index 3");
                                }),
               std::runtime_error);
  EXPECT_EQ(ran.load(), 100);
  // The pool stays usable.
  ran = 0;
  pool.ParallelFor(10, [&](size_t) { ran.fetch_add(1); });
  EXPECT_EQ(ran.load(), 10);
}

}  // namespace
}  // namespace rrslam
