// One persistent thread that runs tasks for a caller that waits for each.
//
// For work that must run in step with its caller but on a thread of its own:
// glibc gives each thread its own heap (arena), so a task's allocations stay
// together in memory instead of filling the holes that an earlier burst of
// the caller's left all over its heap. rrslam-track runs its frame loop this
// way, and in batch mode local mapping and loop closing on a second one:
// after a building-scale map's load, the main heap is gigabytes of live
// objects interleaved with freed ones, and a local bundle adjustment's many
// small blocks scattered through it ran 2.4 times slower than the same
// problem on a compact heap, tracking's pose optimizations 11% of their time
// in malloc's internals (docs/mapstore.md).
#pragma once

#include <condition_variable>
#include <exception>
#include <functional>
#include <mutex>
#include <thread>

namespace rrslam {

class TaskThread {
 public:
  // Starts the thread. Throws ResourceError (exit 75) when it cannot start.
  TaskThread();
  // Joins the thread (after the task it runs, if any).
  ~TaskThread();
  TaskThread(const TaskThread&) = delete;
  TaskThread& operator=(const TaskThread&) = delete;

  // Runs `task` on the thread and returns when it has finished; rethrows
  // what it threw. One task at a time: not reentrant, not for concurrent
  // callers.
  void Run(const std::function<void()>& task);

 private:
  void Loop();

  std::mutex mutex_;
  std::condition_variable wake_, done_;
  const std::function<void()>* task_ = nullptr;
  std::exception_ptr error_;
  bool stop_ = false;
  std::thread thread_;  // Last: starts once the members above exist.
};

}  // namespace rrslam
