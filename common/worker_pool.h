// A fixed set of persistent threads that run index loops with the calling
// thread taking part. Used where a loop runs many times (per frame, per
// k-means iteration) and starting threads each time would cost more than the
// work.
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <exception>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

namespace rrslam {

// Most threads an rrslam tool runs for its --threads option: each tool's
// options Check refuses more (exit 64). Four times the cores of the largest
// machine the tools are meant for; every thread reserves a stack (8 MB of
// address space by default), so thousands would only exhaust memory.
inline constexpr int kMaxThreads = 256;

class WorkerPool {
 public:
  // `threads` in all, the calling thread included (values below 1 count as 1).
  // Throws ResourceError (exit 75) when a thread cannot be started (the
  // system's limit on threads or on address space, `ulimit -v`, is reached),
  // after stopping and joining the threads already started.
  explicit WorkerPool(int threads);
  ~WorkerPool();
  WorkerPool(const WorkerPool&) = delete;
  WorkerPool& operator=(const WorkerPool&) = delete;

  int size() const { return static_cast<int>(workers_.size()) + 1; }

  // Runs fn(i) for every i in [0, n) and returns when all have run. Indices
  // are claimed in increasing order, each by whichever thread is free, so an
  // index may wait for a smaller one (that one has started already) but fn
  // must not depend on which thread runs it. With one thread or n <= 1 the
  // calling thread runs them in order. Rethrows the first exception of fn
  // after every index has been tried. Not reentrant: one loop at a time.
  void ParallelFor(size_t n, const std::function<void(size_t)>& fn);

 private:
  void RunIndices(const std::function<void(size_t)>& fn, size_t n);
  void WorkerLoop();
  void StopAndJoin();

  std::vector<std::thread> workers_;
  std::mutex mutex_;
  std::condition_variable wake_, done_;
  const std::function<void(size_t)>* job_ = nullptr;
  size_t job_size_ = 0;
  std::atomic<size_t> next_{0};
  size_t busy_workers_ = 0;
  uint64_t generation_ = 0;
  bool stop_ = false;
  std::exception_ptr error_;
};

}  // namespace rrslam
