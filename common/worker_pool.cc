#include "common/worker_pool.h"

#include <string>
#include <system_error>

#include "common/errors.h"

namespace rrslam {

WorkerPool::WorkerPool(int threads) {
  workers_.reserve(threads > 1 ? static_cast<size_t>(threads) - 1 : 0);
  for (int i = 1; i < threads; ++i) {
    try {
      workers_.emplace_back([this] { WorkerLoop(); });
    } catch (const std::system_error& e) {
      // The destructor does not run for a constructor that throws: without
      // this, the members would be destroyed under running threads (a
      // condition variable destroyed with waiters blocks for ever).
      StopAndJoin();
      throw ResourceError("cannot start worker thread " + std::to_string(i + 1) + " of " +
                          std::to_string(threads) + " (" + e.what() +
                          "); use fewer threads or raise the memory / thread limits");
    } catch (...) {
      StopAndJoin();
      throw;
    }
  }
}

WorkerPool::~WorkerPool() { StopAndJoin(); }

void WorkerPool::StopAndJoin() {
  {
    std::lock_guard lock(mutex_);
    stop_ = true;
  }
  wake_.notify_all();
  for (std::thread& t : workers_) t.join();
  workers_.clear();
}

void WorkerPool::ParallelFor(size_t n, const std::function<void(size_t)>& fn) {
  if (workers_.empty() || n <= 1) {
    for (size_t i = 0; i < n; ++i) fn(i);
    return;
  }
  {
    std::lock_guard lock(mutex_);
    job_ = &fn;
    job_size_ = n;
    next_ = 0;
    error_ = nullptr;
    busy_workers_ = workers_.size();
    ++generation_;
  }
  wake_.notify_all();
  RunIndices(fn, n);
  std::unique_lock lock(mutex_);
  done_.wait(lock, [&] { return busy_workers_ == 0; });
  job_ = nullptr;
  if (error_) std::rethrow_exception(error_);
}

void WorkerPool::RunIndices(const std::function<void(size_t)>& fn, size_t n) {
  for (size_t i = next_.fetch_add(1); i < n; i = next_.fetch_add(1)) {
    try {
      fn(i);
    } catch (...) {
      std::lock_guard lock(mutex_);
      if (!error_) error_ = std::current_exception();
    }
  }
}

void WorkerPool::WorkerLoop() {
  uint64_t seen = 0;
  std::unique_lock lock(mutex_);
  while (true) {
    wake_.wait(lock, [&] { return stop_ || generation_ != seen; });
    if (stop_) return;
    seen = generation_;
    const auto* job = job_;
    const size_t n = job_size_;
    lock.unlock();
    RunIndices(*job, n);
    lock.lock();
    if (--busy_workers_ == 0) done_.notify_all();
  }
}

}  // namespace rrslam
