#include "common/worker_pool.h"

#include <gtest/gtest.h>
#include <sys/resource.h>
#include <unistd.h>

#include <atomic>
#include <fstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "common/errors.h"

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

// Found in review (issue 36): `rrslam-cluster --threads 1000` under `ulimit
// -v` hung. When a thread could not be started, the constructor threw with
// the threads already started still waiting on its condition variable,
// whose destructor then waited for ever. Now it joins them and throws
// ResourceError (exit 75).
TEST(WorkerPool, ThreadThatCannotStartIsAResourceErrorNotAHang) {
  rlimit old_limit{};
  ASSERT_EQ(getrlimit(RLIMIT_AS, &old_limit), 0);
  size_t used_pages = 0;
  std::ifstream("/proc/self/statm") >> used_pages;
  ASSERT_GT(used_pages, 0u);
  // Room for a few thread stacks (8 MB each by default), not for 256.
  rlimit tight = old_limit;
  tight.rlim_cur = used_pages * static_cast<size_t>(sysconf(_SC_PAGESIZE)) + (size_t{64} << 20);
  if (old_limit.rlim_max != RLIM_INFINITY && tight.rlim_cur > old_limit.rlim_max) {
    GTEST_SKIP() << "address-space limit already below what the test needs";
  }
  ASSERT_EQ(setrlimit(RLIMIT_AS, &tight), 0);
  std::string message;
  try {
    WorkerPool pool(kMaxThreads);
  } catch (const ResourceError& e) {
    message = e.what();
  }
  ASSERT_EQ(setrlimit(RLIMIT_AS, &old_limit), 0);
  EXPECT_EQ(message.rfind("cannot start worker thread ", 0), 0u) << message;
  EXPECT_NE(message.find(" of 256 ("), std::string::npos) << message;
  EXPECT_EQ(message.find('\n'), std::string::npos) << message;
  // Nothing is left behind: pools work as before.
  WorkerPool pool(4);
  std::atomic<int> ran{0};
  pool.ParallelFor(100, [&](size_t) { ran.fetch_add(1); });
  EXPECT_EQ(ran.load(), 100);
}

}  // namespace
}  // namespace rrslam
