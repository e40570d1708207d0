// What the benchmark drivers (bench/<name>/bench_<name>.cc) share: running a
// command line (or a child process measured: wall time, CPU time, peak
// memory), and a report of figures beside their goals written as text
// and JSON to bench/results/.
#pragma once

#include <fcntl.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "common/atomic_file.h"
#include "common/clock.h"
#include "common/text.h"

namespace rrslam::bench {

using nlohmann::ordered_json;

// `p` as one shell word.
inline std::string Quote(const std::filesystem::path& p) { return ShellQuote(p.string()); }

// Runs a command line; returns its exit status and echoes it to stderr.
inline int Run(const std::string& command) {
  std::cerr << "bench: " << command << std::endl;
  const int status = std::system(command.c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

struct ChildRun {
  int exit_code = -1;
  double wall_s = 0;
  double cpu_s = 0;         // User + system.
  double max_rss_mb = 0;    // 10^6 bytes.
  std::string stdout_text;  // What the child printed on stdout.
};

// The peak resident memory of process `pid` since its exec (VmHWM of
// /proc/<pid>/status), kB; 0 when it cannot be read (the process is gone).
inline double PeakResidentKb(pid_t pid) {
  std::ifstream status("/proc/" + std::to_string(pid) + "/status");
  std::string line;
  while (std::getline(status, line)) {
    if (line.rfind("VmHWM:", 0) == 0) return std::atof(line.c_str() + 6);
  }
  return 0;
}

// Waits for child `pid` (past its exec); its rusage in `usage`, and the
// largest VmHWM read while it ran (every 2 ms; kB). wait4's ru_maxrss alone
// is no peak of the child's own: Linux counts in it the resident memory the
// child had before its exec, a copy of this process's, which holds
// gigabytes of map after a big in-process load (then a child of a few MB
// reported 1.9 GB).
inline pid_t WaitWatchingPeak(pid_t pid, int* status, struct rusage* usage, double* peak_kb) {
  for (;;) {
    const pid_t done = wait4(pid, status, WNOHANG, usage);
    if (done != 0) return done;
    *peak_kb = std::max(*peak_kb, PeakResidentKb(pid));
    usleep(2000);
  }
}

// Runs argv[0] with its arguments (stdout captured to `capture`, stderr
// passed through) and measures it with wait4.
inline ChildRun RunChild(const std::vector<std::string>& argv,
                         const std::filesystem::path& capture) {
  std::string line;
  for (const std::string& a : argv) line += ShellQuote(a) + " ";
  std::cerr << "bench: " << line << "> " << capture.string() << std::endl;
  ChildRun run;
  const auto start = SteadyClock::now();
  // Closed in the child by its exec (O_CLOEXEC): the end of the copy of
  // this process that the fork made, whose VmHWM is not the child's.
  int exec_pipe[2] = {-1, -1};
  if (pipe2(exec_pipe, O_CLOEXEC) != 0) return run;
  const pid_t pid = fork();
  if (pid == 0) {
    close(exec_pipe[0]);
    if (std::freopen(capture.c_str(), "w", stdout) == nullptr) _exit(126);
    std::vector<char*> args;
    for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
    args.push_back(nullptr);
    execv(args[0], args.data());
    _exit(127);
  }
  close(exec_pipe[1]);
  char byte = 0;
  while (pid > 0 && read(exec_pipe[0], &byte, 1) < 0 && errno == EINTR) {
  }
  close(exec_pipe[0]);
  int status = 0;
  struct rusage usage {};
  double peak_kb = 0;
  if (pid < 0 || WaitWatchingPeak(pid, &status, &usage, &peak_kb) != pid) return run;
  run.wall_s = MillisecondsSince(start) / 1000.0;
  run.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  run.cpu_s = usage.ru_utime.tv_sec + usage.ru_utime.tv_usec * 1e-6 + usage.ru_stime.tv_sec +
              usage.ru_stime.tv_usec * 1e-6;
  // The last 2 ms of a run are not watched: a process whose peak came then
  // (or that ended before the first look) falls back to ru_maxrss.
  run.max_rss_mb = (peak_kb > 0 ? peak_kb : usage.ru_maxrss) * 1024.0 / 1e6;
  std::ifstream in(capture);
  std::stringstream text;
  text << in.rdbuf();
  run.stdout_text = text.str();
  return run;
}

inline double Median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

// Nearest-rank percentile, q in (0, 1]; 0 for no values.
inline double Percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  const auto rank = static_cast<size_t>(std::ceil(q * static_cast<double>(v.size())));
  return v[std::clamp<size_t>(rank, 1, v.size()) - 1];
}

struct Figure {
  std::string name;
  double value;
  std::string unit;
  std::string goal;  // Human-readable, e.g. "<= 4.3 cm".
  bool pass;
};

class Report {
 public:
  void Add(const std::string& section, const Figure& f) { figures_.emplace_back(section, f); }
  void Note(const std::string& section, const std::string& text) {
    notes_.emplace_back(section, text);
  }
  bool AllPass() const {
    for (const auto& [s, f] : figures_) {
      if (!f.pass) return false;
    }
    return true;
  }
  std::string Text() const {
    // Columns as wide as their longest entry (at least 44, 18, 16), two
    // spaces apart.
    size_t name_width = 42, value_width = 16, goal_width = 14;
    for (const auto& [s, f] : figures_) {
      name_width = std::max(name_width, f.name.size());
      value_width = std::max(value_width, ValueText(f).size());
      goal_width = std::max(goal_width, f.goal.size() + 5);
    }
    std::ostringstream out;
    std::string section;
    for (const auto& [s, f] : figures_) {
      if (s != section) {
        out << "\n[" << s << "]\n";
        section = s;
        for (const auto& [ns, text] : notes_) {
          if (ns == s) out << "  # " << text << "\n";
        }
      }
      out << "  " << std::left << std::setw(name_width + 2) << f.name << std::setw(value_width + 2)
          << ValueText(f) << std::setw(goal_width + 2) << ("goal " + f.goal)
          << (f.pass ? "PASS" : "FAIL") << "\n";
    }
    return out.str();
  }
  ordered_json Json() const {
    ordered_json j = ordered_json::array();
    for (const auto& [s, f] : figures_) {
      j.push_back({{"section", s},
                   {"figure", f.name},
                   {"value", f.value},
                   {"unit", f.unit},
                   {"goal", f.goal},
                   {"pass", f.pass}});
    }
    return j;
  }

 private:
  static std::string ValueText(const Figure& f) {
    std::ostringstream value;
    value << std::setprecision(6) << f.value << " " << f.unit;
    return value.str();
  }

  std::vector<std::pair<std::string, Figure>> figures_;
  std::vector<std::pair<std::string, std::string>> notes_;
};

// Writes PREFIX.txt (the `title` line, the command, the machine, the
// report and whether every goal is met) and PREFIX.json, each atomically,
// and prints the text: the results of a benchmark driver.
inline void WriteGoalResults(const std::string& out_prefix, const std::string& title,
                             const std::string& command, const std::string& machine,
                             const Report& report) {
  std::ostringstream text;
  text << "# " << title << " (command: " << command << ")\n";
  text << "# machine: " << machine << "\n";
  text << report.Text();
  text << "\nall goals met: " << (report.AllPass() ? "yes" : "no") << "\n";
  ordered_json j;
  j["machine"] = machine;
  j["figures"] = report.Json();
  j["all_goals_met"] = report.AllPass();
  WriteFileAtomically(out_prefix + ".txt", text.str());
  WriteFileAtomically(out_prefix + ".json", j.dump(2) + "\n");
  std::cout << text.str();
}

}  // namespace rrslam::bench
