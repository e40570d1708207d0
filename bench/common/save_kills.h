// SIGKILL at random moments of a run that saves over an existing file
// (`make bench-map`'s kills during --save-map, `make bench-lifelong`'s during
// a merge): what the killed runs leave must be the old file, intact, or the
// new one, complete; never a broken one. Saves go through rrslam::AtomicFile
// (a temporary file beside the target, renamed over it).
//
// Times are wall-clock seconds, measured from the run's start or from its
// save's first bytes (KillClock).
#pragma once

#include <fcntl.h>
#include <signal.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdint>
#include <filesystem>
#include <optional>
#include <random>
#include <set>
#include <string>
#include <vector>

#include "bench/common/bench_report.h"
#include "common/atomic_file.h"
#include "common/clock.h"
#include "common/text.h"

namespace rrslam::bench {

// Temporary files a save into `target` makes (rrslam::AtomicFile: the
// target's name, a random part, ".tmp", in its folder).
inline std::set<std::string> TemporaryFilesOf(const std::filesystem::path& target) {
  std::set<std::string> out;
  const std::string prefix = target.filename().string() + ".";
  std::error_code ec;
  for (const auto& entry : std::filesystem::directory_iterator(target.parent_path(), ec)) {
    const std::string name = entry.path().filename().string();
    if (name.rfind(prefix, 0) == 0 && name.size() > 4 &&
        name.compare(name.size() - 4, 4, ".tmp") == 0) {
      out.insert(name);
    }
  }
  return out;
}

// Whether a temporary file of `target` not in `before` has bytes: rrslam
// creates it when it starts (so that an unwritable path fails at once) and
// writes it when it saves.
inline bool SaveStarted(const std::filesystem::path& target, const std::set<std::string>& before) {
  for (const std::string& name : TemporaryFilesOf(target)) {
    std::error_code ec;
    if (!before.count(name) && std::filesystem::file_size(target.parent_path() / name, ec) > 0 &&
        !ec) {
      return true;
    }
  }
  return false;
}

inline uint64_t InodeOf(const std::filesystem::path& path) {
  struct stat st {};
  return stat(path.c_str(), &st) == 0 ? static_cast<uint64_t>(st.st_ino) : 0;
}

// Where a kill's moment is measured from: the run's start, its save's first
// bytes, or the first line of its standard error holding the marker.
enum class KillClock { kRunStart, kSaveStart, kMarker };

// A run of a command that saves into a file. Times in ms from the run's start.
struct SaveRun {
  bool killed = false;  // False: it ended on its own.
  // The save's first bytes in the temporary file, the rename over the
  // target (the target's inode changing), the first line of standard error
  // holding the marker, and the run's end.
  std::optional<double> save_ms, rename_ms, marker_ms, end_ms;
};

// Lines of a child's standard error, read without blocking; whether one
// held `marker` so far.
class MarkerWatch {
 public:
  MarkerWatch(int fd, std::string marker) : fd_(fd), marker_(std::move(marker)) {
    fcntl(fd_, F_SETFL, fcntl(fd_, F_GETFL) | O_NONBLOCK);
  }
  ~MarkerWatch() { close(fd_); }
  // Reads what is there (call it often: a full pipe would stop the child).
  bool Seen() {
    char buffer[4096];
    ssize_t n;
    while ((n = read(fd_, buffer, sizeof buffer)) > 0) {
      text_.append(buffer, static_cast<size_t>(n));
      seen_ = seen_ || text_.find(marker_) != std::string::npos;
      if (text_.size() > marker_.size()) text_.erase(0, text_.size() - marker_.size());
    }
    return seen_;
  }

 private:
  int fd_;
  std::string marker_, text_;  // text_: the tail a marker may continue.
  bool seen_ = false;
};

// Runs `argv`, watching for a save into `target` (SaveStarted) and, with a
// `marker`, for it on the run's standard error (then not shown); with
// `kill_after_s`, kills it with SIGKILL that many seconds after `clock`'s
// origin, unless it ended before the origin or the kill.
inline SaveRun RunWatchingSave(const std::vector<std::string>& argv,
                               const std::filesystem::path& target,
                               std::optional<double> kill_after_s,
                               KillClock clock = KillClock::kSaveStart,
                               const std::string& marker = "") {
  const std::set<std::string> before = TemporaryFilesOf(target);
  const uint64_t old_inode = InodeOf(target);
  int err_pipe[2] = {-1, -1};
  if (!marker.empty() && pipe(err_pipe) != 0) return {};
  const auto start = SteadyClock::now();
  const pid_t pid = fork();
  if (pid == 0) {
    if (!marker.empty()) {
      dup2(err_pipe[1], STDERR_FILENO);
      close(err_pipe[0]);
      close(err_pipe[1]);
    }
    std::vector<char*> args;
    for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
    args.push_back(nullptr);
    execv(args[0], args.data());
    _exit(127);
  }
  std::optional<MarkerWatch> watch;
  if (!marker.empty()) {
    close(err_pipe[1]);
    watch.emplace(err_pipe[0], marker);
  }
  SaveRun run;
  int status = 0;
  while (waitpid(pid, &status, WNOHANG) != pid) {
    const double now_ms = MillisecondsSince(start);
    if (!run.save_ms && SaveStarted(target, before)) run.save_ms = now_ms;
    if (run.save_ms && !run.rename_ms && InodeOf(target) != old_inode) run.rename_ms = now_ms;
    if (watch && watch->Seen() && !run.marker_ms) run.marker_ms = now_ms;
    const std::optional<double> origin_ms = clock == KillClock::kRunStart    ? 0.0
                                            : clock == KillClock::kSaveStart ? run.save_ms
                                                                             : run.marker_ms;
    if (kill_after_s && origin_ms && now_ms - *origin_ms >= *kill_after_s * 1000) {
      kill(pid, SIGKILL);
      waitpid(pid, &status, 0);
      run.killed = WIFSIGNALED(status);
      break;
    }
    usleep(200);
  }
  run.end_ms = MillisecondsSince(start);
  return run;
}

// A save over an existing file, and what its target may rightly hold.
struct SaveOverFile {
  std::vector<std::string> argv;
  std::filesystem::path original, target;  // The existing file; its copy the run saves over.
  std::string old_bytes;                   // The target before the run.
  std::string new_bytes;                   // The target after a run that is not killed.
};

// What the killed runs left.
struct KillCounts {
  int intact_old = 0, complete_new = 0, broken = 0, killed = 0;
  size_t left_behind = 0;  // Temporary files (removed).
};

// Runs the save `kills` times, each killed at a moment uniform in
// [from_s, to_s] after `clock`'s origin (`marker`: RunWatchingSave's); the
// target is restored from the original before each run.
inline KillCounts KillDuringSaves(const SaveOverFile& save, double from_s, double to_s,
                                  KillClock clock, int kills, const std::string& marker = "") {
  std::mt19937 rng(13);
  std::uniform_real_distribution<double> when(from_s, to_s);
  KillCounts c;
  for (int k = 0; k < kills; ++k) {
    std::filesystem::copy_file(save.original, save.target,
                               std::filesystem::copy_options::overwrite_existing);
    c.killed += RunWatchingSave(save.argv, save.target, when(rng), clock, marker).killed;
    for (const std::string& name : TemporaryFilesOf(save.target)) {
      std::filesystem::remove(save.target.parent_path() / name);
      ++c.left_behind;
    }
    const std::string now = ReadFileToString(save.target);
    if (now == save.old_bytes) {
      ++c.intact_old;
    } else if (now == save.new_bytes) {
      ++c.complete_new;
    } else {
      ++c.broken;
    }
  }
  return c;
}

// The counts as figures of section `s` (goal: no broken file), after `note`.
inline void AddKillCounts(const KillCounts& c, int kills, const std::string& note,
                          const std::string& s, Report* report) {
  report->Note(s, note);
  report->Add(s, {"runs killed", double(c.killed), "of " + std::to_string(kills), "-", true});
  report->Add(s, {"previous map intact", double(c.intact_old), "", "-", true});
  report->Add(
      s, {"new map complete (killed after the rename)", double(c.complete_new), "", "-", true});
  report->Add(s, {"map file neither (corrupt)", double(c.broken), "", "0", c.broken == 0});
  report->Add(
      s, {"temporary files left by killed runs (removed)", double(c.left_behind), "", "-", true});
}

}  // namespace rrslam::bench
