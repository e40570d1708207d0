#include "common/progress.h"

#include <unistd.h>

#include <cstdio>

namespace rrslam {
namespace {
std::atomic<bool> g_quiet{false};

std::string FormatDuration(double seconds) {
  if (!(seconds >= 0) || seconds > 99 * 3600) return "--:--";
  const long s = static_cast<long>(seconds + 0.5);
  char buf[32];
  if (s >= 3600) {
    std::snprintf(buf, sizeof(buf), "%ld:%02ld:%02ld", s / 3600, (s / 60) % 60, s % 60);
  } else {
    std::snprintf(buf, sizeof(buf), "%ld:%02ld", s / 60, s % 60);
  }
  return buf;
}
}  // namespace

void SetProgressQuiet(bool quiet) { g_quiet = quiet; }

ProgressBar::ProgressBar(std::string label, size_t total, std::string unit)
    : label_(std::move(label)),
      unit_(std::move(unit)),
      total_(total),
      enabled_(!g_quiet && ::isatty(STDERR_FILENO)),
      start_(std::chrono::steady_clock::now()),
      last_draw_(start_) {}

ProgressBar::~ProgressBar() { Finish(); }

void ProgressBar::Advance(size_t n) {
  done_ += n;
  if (!enabled_) return;
  const auto now = std::chrono::steady_clock::now();
  std::unique_lock lock(mutex_, std::try_to_lock);
  if (!lock.owns_lock() || finished_) return;
  if (now - last_draw_ < std::chrono::milliseconds(100)) return;
  last_draw_ = now;
  Draw(false);
}

void ProgressBar::Finish() {
  std::lock_guard lock(mutex_);
  if (finished_) return;
  finished_ = true;
  if (enabled_) {
    Draw(true);
    std::fputc('\n', stderr);
    std::fflush(stderr);
  }
}

void ProgressBar::Draw(bool final_draw) {
  const size_t done = done_.load();
  const double elapsed =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  const double rate = elapsed > 0 ? done / elapsed : 0.0;
  char line[256];
  if (total_ > 0) {
    const double fraction = std::min(1.0, static_cast<double>(done) / total_);
    constexpr int kWidth = 24;
    const int filled = static_cast<int>(fraction * kWidth);
    std::string bar(filled, '#');
    bar.append(kWidth - filled, '.');
    const double eta = rate > 0 ? (total_ - std::min(done, total_)) / rate : -1;
    std::snprintf(line, sizeof(line), "\r%s [%s] %zu/%zu %5.1f%% %.1f %s/s %s %s", label_.c_str(),
                  bar.c_str(), done, total_, 100.0 * fraction, rate, unit_.c_str(),
                  final_draw ? "in" : "ETA", FormatDuration(final_draw ? elapsed : eta).c_str());
  } else {
    std::snprintf(line, sizeof(line), "\r%s %zu %s %.1f %s/s %s", label_.c_str(), done,
                  unit_.c_str(), rate, unit_.c_str(), FormatDuration(elapsed).c_str());
  }
  std::fputs(line, stderr);
  std::fputs("\033[K", stderr);  // Clear the rest of a longer previous line.
  std::fflush(stderr);
}

}  // namespace rrslam
