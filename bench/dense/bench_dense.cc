// bench_dense: `rrslam-render dense` on a real map (`make bench-dense`).
//
//   bench_dense --render BIN --map MAP --sequence DIR --work DIR [--runs N]
//               [--voxel M] [--cap-voxel M] [--refuse-voxel M] --machine TEXT
//               --out PREFIX
// Runs `BIN --quiet dense --map MAP --sequence DIR --out WORK/model.ply
// --voxel M` N times as a child process and measures each run's wall time and
// peak memory (the child's ru_maxrss from wait4) and CPU time; reads the
// PLY back (points, normals, colours, keyframes fused, from its comments) and
// the stage figures rrslam-render prints (bounds, fuse, export, write
// seconds). Then once with --voxel CAP, whose voxel grid is close to the
// default --max-volume-gb (3 GiB): the process must stay within 4 GB, which
// is what that default promises; and once with --voxel REFUSE, whose volume
// exceeds it: refused (exit 64) before any fusion.
// Goals: wall time <= 60 s (median of the runs) and peak memory <= 4 GB
// (the largest of the runs), on 2 cores.
// Writes PREFIX.txt and PREFIX.json; exit status 0 when every run completed.
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include "bench/common/bench_report.h"
#include "common/atomic_file.h"
#include "common/clock.h"
#include "common/text.h"
#include "stages/mapstore/map_file.h"
#include "stages/render/ply.h"

namespace {

namespace fs = std::filesystem;
using nlohmann::ordered_json;
using rrslam::bench::Figure;
using rrslam::bench::Report;

struct ChildRun {
  int exit_code = -1;
  double wall_s = 0;
  double cpu_s = 0;         // User + system.
  double max_rss_mb = 0;    // 10^6 bytes.
  std::string stdout_text;  // What the child printed on stdout.
};

// Runs argv[0] with its arguments (stdout captured to `capture`, stderr
// passed through) and measures it with wait4.
ChildRun RunChild(const std::vector<std::string>& argv, const fs::path& capture) {
  std::string line;
  for (const std::string& a : argv) line += rrslam::ShellQuote(a) + " ";
  std::cerr << "bench: " << line << "> " << capture.string() << std::endl;
  ChildRun run;
  const auto start = rrslam::SteadyClock::now();
  const pid_t pid = fork();
  if (pid == 0) {
    if (std::freopen(capture.c_str(), "w", stdout) == nullptr) _exit(126);
    std::vector<char*> args;
    for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
    args.push_back(nullptr);
    execv(args[0], args.data());
    _exit(127);
  }
  int status = 0;
  struct rusage usage {};
  if (pid < 0 || wait4(pid, &status, 0, &usage) != pid) return run;
  run.wall_s = rrslam::MillisecondsSince(start) / 1000.0;
  run.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  run.cpu_s = usage.ru_utime.tv_sec + usage.ru_utime.tv_usec * 1e-6 + usage.ru_stime.tv_sec +
              usage.ru_stime.tv_usec * 1e-6;
  run.max_rss_mb = usage.ru_maxrss * 1024.0 / 1e6;  // Linux: kilobytes.
  std::ifstream in(capture);
  std::stringstream text;
  text << in.rdbuf();
  run.stdout_text = text.str();
  return run;
}

double Median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

// "<name> X s" from rrslam-render dense's summary line; -1 when absent.
double StageSeconds(const std::string& summary, const std::string& name) {
  std::smatch match;
  if (std::regex_search(summary, match, std::regex(name + " ([0-9.]+) s"))) {
    return std::stod(match[1]);
  }
  return -1;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app("Measures rrslam-render dense on a real map.");
  fs::path render, map, sequence, work;
  int runs = 3;
  double voxel = 0.01, refuse_voxel = 0.004, cap_voxel = 0.0052;
  std::string machine, out_prefix;
  app.add_option("--render", render, "The rrslam-render executable")->required();
  app.add_option("--map", map, "Map file (rrslam.map)")->required();
  app.add_option("--sequence", sequence, "The RGB-D sequence it was built from")->required();
  app.add_option("--work", work, "Folder for the outputs")->required();
  app.add_option("--runs", runs, "Measured runs")->capture_default_str();
  app.add_option("--voxel", voxel, "Voxel, metres")->capture_default_str();
  app.add_option("--refuse-voxel", refuse_voxel,
                 "A voxel whose volume exceeds the default cap (0: skip)")
      ->capture_default_str();
  app.add_option("--cap-voxel", cap_voxel,
                 "A voxel whose volume is near the default cap: one run, its peak memory (0: skip)")
      ->capture_default_str();
  app.add_option("--machine", machine, "Machine description line");
  app.add_option("--out", out_prefix, "Result files prefix (writes .txt and .json)")->required();
  CLI11_PARSE(app, argc, argv);
  fs::create_directories(work);
  auto load_average = [] {
    std::ifstream in("/proc/loadavg");
    std::string a, b, c;
    in >> a >> b >> c;
    return a + " " + b + " " + c;
  };
  const std::string load_before = load_average();

  const rrslam::MapData map_data = rrslam::ReadMapFile(map);
  const size_t keyframes = map_data.keyframes.size();
  auto format = [](double value) {
    char text[32];
    std::snprintf(text, sizeof(text), "%g", value);
    return std::string(text);
  };
  auto make_command = [&](const fs::path& out, double v) {
    return std::vector<std::string>{render.string(), "--quiet",    "dense",           "--map",
                                    map.string(),    "--sequence", sequence.string(), "--out",
                                    out.string(),    "--voxel",    format(v)};
  };
  const std::string voxel_text = format(voxel);
  const fs::path ply = work / "model.ply";
  const std::vector<std::string> command = make_command(ply, voxel);
  std::string command_line;
  for (const std::string& a : command) command_line += (command_line.empty() ? "" : " ") + a;

  Report report;
  const std::string s = "dense, " + map.filename().string() + ", --voxel " + voxel_text;
  report.Note(s, "command: " + command_line);
  report.Note(s, "map: " + map.string() + " (" + std::to_string(keyframes) + " keyframes), " +
                     "sequence: " + sequence.string());
  std::vector<double> walls, cpus, rss, fuse, export_s, color, bounds, write;
  bool failed = false;
  std::string summary;
  for (int r = 0; r < runs; ++r) {
    const ChildRun run = RunChild(command, work / "stdout.txt");
    if (run.exit_code != 0) {
      std::cerr << "bench_dense: run " << r << " exited " << run.exit_code << "\n";
      failed = true;
      break;
    }
    walls.push_back(run.wall_s);
    cpus.push_back(run.cpu_s);
    rss.push_back(run.max_rss_mb);
    bounds.push_back(StageSeconds(run.stdout_text, "bounds"));
    fuse.push_back(StageSeconds(run.stdout_text, "fuse"));
    export_s.push_back(StageSeconds(run.stdout_text, "export"));
    color.push_back(StageSeconds(run.stdout_text, "colour"));
    write.push_back(StageSeconds(run.stdout_text, "write"));
    summary = run.stdout_text.substr(0, run.stdout_text.find('\n'));
  }
  if (!failed && !walls.empty()) {
    const rrslam::PlyCloud cloud = rrslam::ReadPly(ply);
    size_t fused = 0;
    for (const std::string& c : cloud.comments) {
      if (c.rfind("keyframes_fused ", 0) == 0) fused = std::stoul(c.substr(16));
    }
    const double peak = *std::max_element(rss.begin(), rss.end());
    const double wall = Median(walls);
    report.Note(s, "rrslam-render: " + summary);
    report.Add(s, {"wall time (median of " + std::to_string(walls.size()) + ")", wall, "s",
                   "<= 60 s", wall <= 60});
    report.Add(s, {"  slowest run", *std::max_element(walls.begin(), walls.end()), "s", "-", true});
    report.Add(s, {"  reading depth for the bounds (median)", Median(bounds), "s", "-", true});
    report.Add(s, {"  volume, reading images, fusing (median)", Median(fuse), "s", "-", true});
    report.Add(s, {"  surface points and raycast (median)", Median(export_s), "s", "-", true});
    report.Add(s, {"  colours from the keyframes (median)", Median(color), "s", "-", true});
    report.Add(s, {"  writing PLY and PNG (median)", Median(write), "s", "-", true});
    report.Add(s, {"CPU time / wall time (median)", Median(cpus) / wall, "cores", "-", true});
    report.Add(s, {"peak memory (max RSS, largest run)", peak, "MB", "<= 4000 MB", peak <= 4000});
    report.Add(s, {"keyframes fused", static_cast<double>(fused), "of " + std::to_string(keyframes),
                   "all", fused == keyframes});
    report.Add(
        s, {"surface points exported", static_cast<double>(cloud.positions.size()), "", "-", true});
    const bool complete = cloud.normals.size() == cloud.positions.size() &&
                          cloud.colors.size() == cloud.positions.size();
    report.Add(s,
               {"every point has a normal and a colour", complete ? 1.0 : 0.0, "", "1", complete});
    report.Add(s, {"PLY size", static_cast<double>(fs::file_size(ply)) / 1e6, "MB", "-", true});
  } else {
    report.Add(s, {"runs completed", static_cast<double>(walls.size()),
                   "of " + std::to_string(runs), "all", false});
  }

  if (cap_voxel > 0) {
    const std::string c = "volume near the memory cap (--voxel " + format(cap_voxel) + ")";
    const ChildRun run = RunChild(make_command(work / "cap.ply", cap_voxel), work / "cap.txt");
    std::smatch match;
    if (run.exit_code == 0 && std::regex_search(run.stdout_text, match,
                                                std::regex("voxels of [0-9.]+ m \\(([0-9]+) MB"))) {
      report.Note(c, "rrslam-render: " + run.stdout_text.substr(0, run.stdout_text.find('\n')));
      report.Add(c, {"voxel grid", std::stod(match[1]), "MB",
                     "<= " + std::to_string(static_cast<int>(3 * 1073.741824)) + " MB (3 GiB)",
                     std::stod(match[1]) <= 3 * 1073.741824});
    }
    report.Add(c, {"exit code", static_cast<double>(run.exit_code), "", "0", run.exit_code == 0});
    report.Add(c, {"wall time", run.wall_s, "s", "-", true});
    report.Add(c, {"peak memory (max RSS)", run.max_rss_mb, "MB", "<= 4000 MB",
                   run.exit_code == 0 && run.max_rss_mb <= 4000});
    failed = failed || run.exit_code != 0;
  }

  if (refuse_voxel > 0) {
    const std::string r = "volume above the memory cap (--voxel " + format(refuse_voxel) + ")";
    const ChildRun run =
        RunChild(make_command(work / "refused.ply", refuse_voxel), work / "refused.txt");
    report.Add(r, {"exit code", static_cast<double>(run.exit_code), "", "64", run.exit_code == 64});
    report.Add(r, {"time to refusal", run.wall_s, "s", "<= 5 s", run.wall_s <= 5});
    report.Add(r, {"peak memory", run.max_rss_mb, "MB", "-", true});
    report.Add(r, {"no output written", fs::exists(work / "refused.ply") ? 0.0 : 1.0, "", "1",
                   !fs::exists(work / "refused.ply")});
  }

  std::ostringstream text;
  text << "# bench-dense: rrslam-render dense on a real map (command: make bench-dense)\n";
  text << "# machine: " << machine << "\n";
  text << "# load average (1, 5, 15 min) before: " << load_before << ", after: " << load_average()
       << "\n";
  text << report.Text();
  text << "\nall goals met: " << (report.AllPass() ? "yes" : "no") << "\n";
  ordered_json j;
  j["machine"] = machine;
  j["load_average_before"] = load_before;
  j["command"] = command_line;
  j["figures"] = report.Json();
  j["all_goals_met"] = report.AllPass();
  rrslam::WriteFileAtomically(out_prefix + ".txt", text.str());
  rrslam::WriteFileAtomically(out_prefix + ".json", j.dump(2) + "\n");
  std::cout << text.str();
  return failed ? 1 : 0;
}
