// A progress bar on stderr with rate and ETA.
//
// Drawn only when stderr is a terminal and quiet mode is off (`--quiet`, see
// SetProgressQuiet); otherwise it prints nothing, so logs and CI output stay
// clean. Redraws at most ten times a second. Advance() is thread-safe.
#pragma once

#include <atomic>
#include <chrono>
#include <cstddef>
#include <mutex>
#include <string>

namespace rrslam {

// Turns every progress bar of the process off (true) or back on (false).
void SetProgressQuiet(bool quiet);

class ProgressBar {
 public:
  // `label` names the work ("extract"); `total` is the number of items, or 0
  // when unknown (then only the count and rate are shown); `unit` names an item.
  ProgressBar(std::string label, size_t total, std::string unit = "it");
  ~ProgressBar();  // Calls Finish().
  ProgressBar(const ProgressBar&) = delete;
  ProgressBar& operator=(const ProgressBar&) = delete;

  // Marks `n` more items done.
  void Advance(size_t n = 1);
  // Draws the final state and ends the line. Idempotent.
  void Finish();

  size_t done() const { return done_.load(); }

 private:
  void Draw(bool final_draw);

  std::string label_;
  std::string unit_;
  size_t total_;
  bool enabled_;
  bool finished_ = false;
  std::atomic<size_t> done_{0};
  std::chrono::steady_clock::time_point start_;
  std::chrono::steady_clock::time_point last_draw_;
  std::mutex mutex_;
};

}  // namespace rrslam
