#include "common/task_thread.h"

#include <string>
#include <system_error>
#include <utility>

#include "common/errors.h"

namespace rrslam {

TaskThread::TaskThread() {
  try {
    thread_ = std::thread([this] { Loop(); });
  } catch (const std::system_error& e) {
    throw ResourceError(std::string("cannot start a thread (") + e.what() +
                        "); raise the memory / thread limits");
  }
}

TaskThread::~TaskThread() {
  {
    std::lock_guard lock(mutex_);
    stop_ = true;
  }
  wake_.notify_one();
  thread_.join();
}

void TaskThread::Run(const std::function<void()>& task) {
  std::unique_lock lock(mutex_);
  task_ = &task;
  error_ = nullptr;
  wake_.notify_one();
  done_.wait(lock, [&] { return task_ == nullptr; });
  if (error_) std::rethrow_exception(std::exchange(error_, nullptr));
}

void TaskThread::Loop() {
  std::unique_lock lock(mutex_);
  while (true) {
    wake_.wait(lock, [&] { return stop_ || task_ != nullptr; });
    if (task_ == nullptr) return;  // Stopped with nothing to run.
    const std::function<void()>& task = *task_;
    lock.unlock();
    std::exception_ptr error;
    try {
      task();
    } catch (...) {
      error = std::current_exception();
    }
    lock.lock();
    error_ = error;
    task_ = nullptr;
    done_.notify_one();
  }
}

}  // namespace rrslam
