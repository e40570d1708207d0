// bench_octomap: `rrslam-render octomap` and `grid` on a real map
// (`make bench-octomap`).
//
//   bench_octomap --render BIN --map MAP --sequence DIR --work DIR [--runs N]
//                 [--resolution M] --machine TEXT --out PREFIX
// Runs `BIN --quiet octomap --map MAP --sequence DIR --out WORK/map.bt
// --resolution M` N times as a child process (wall time, CPU time, peak
// memory from wait4); reads the file with octomap-tools' edit_octree (the
// node count it reports against the one rrslam-render prints); then runs
// `grid` once and reads how many keyframe cameras stand over free cells.
// Goals (issue 32): <= 60 s (median) and <= 2 GB peak at 5 cm on 2 cores;
// octomap-tools read the file. The cameras over free cells are reported: a
// hand-held camera held over a table stands over an occupied cell.
// Writes PREFIX.txt and PREFIX.json; exit status 0 when every run completed.
#include <CLI/CLI.hpp>
#include <regex>
#include <string>
#include <vector>

#include "bench/common/bench_report.h"

namespace {

namespace fs = std::filesystem;
using rrslam::bench::ChildRun;
using rrslam::bench::Median;
using rrslam::bench::Report;
using rrslam::bench::RunChild;

struct Options {
  fs::path render, map, sequence, work;
  int runs = 3;
  double resolution = 0.05;
  std::string machine, out;
};

// The integer after `pattern` (a regex with one group) in `text`, or -1.
long long Find(const std::string& text, const std::string& pattern) {
  std::smatch match;
  return std::regex_search(text, match, std::regex(pattern)) ? std::stoll(match[1]) : -1;
}

void Integration(const Options& o, Report* report, std::string* nodes) {
  const std::string s = "octomap at " + rrslam::Format("%g", o.resolution) + " m";
  const std::vector<std::string> command = {o.render.string(),
                                            "--quiet",
                                            "octomap",
                                            "--map",
                                            o.map.string(),
                                            "--sequence",
                                            o.sequence.string(),
                                            "--out",
                                            (o.work / "map.bt").string(),
                                            "--resolution",
                                            rrslam::Format("%g", o.resolution)};
  std::vector<double> walls, cpus, rss;
  ChildRun last;
  for (int r = 0; r < o.runs; ++r) {
    last = RunChild(command, o.work / "octomap.txt");
    if (last.exit_code != 0) {
      report->Add(s, {"exit code", static_cast<double>(last.exit_code), "", "0", false});
      return;
    }
    walls.push_back(last.wall_s);
    cpus.push_back(last.cpu_s);
    rss.push_back(last.max_rss_mb);
  }
  const double peak = *std::max_element(rss.begin(), rss.end());
  report->Note(s, "rrslam-render: " + last.stdout_text.substr(0, last.stdout_text.find('\n')));
  report->Add(s, {"wall time (median of " + std::to_string(o.runs) + ")", Median(walls), "s",
                  "<= 60 s", Median(walls) <= 60});
  report->Add(s, {"CPU time (median)", Median(cpus), "s", "-", true});
  report->Add(s, {"peak memory (largest)", peak, "MB", "<= 2000 MB", peak <= 2000});
  const long long leaves = Find(last.stdout_text, "nodes \\(([0-9]+) leaves");
  report->Add(s, {"leaves", static_cast<double>(leaves), "", "-", leaves > 0});
  *nodes = std::to_string(Find(last.stdout_text, "tree of ([0-9]+) nodes"));
}

void ReadByOctomapTools(const Options& o, const std::string& nodes, Report* report) {
  const std::string s = "octomap-tools";
  const fs::path log = o.work / "edit_octree.txt";
  const int code = rrslam::bench::Run("edit_octree -o " + rrslam::bench::Quote(o.work / "copy.bt") +
                                      " " + rrslam::bench::Quote(o.work / "map.bt") + " > " +
                                      rrslam::bench::Quote(log) + " 2>&1");
  const std::string text = rrslam::ReadFileToString(log);
  const bool same = text.find("Writing " + nodes + " nodes") != std::string::npos;
  report->Note(s, "edit_octree -o copy.bt map.bt: reads the file, writes it again");
  report->Add(s, {"edit_octree exit code", static_cast<double>(code), "", "0", code == 0});
  report->Add(s, {"nodes edit_octree read = rrslam's", same ? 1.0 : 0.0, "", "1", same});
}

void Grid(const Options& o, Report* report) {
  const std::string s = "grid 0.1-1.5 m above the floor";
  const ChildRun run =
      RunChild({o.render.string(), "--quiet", "grid", "--map", o.map.string(), "--sequence",
                o.sequence.string(), "--out", (o.work / "grid.yaml").string(), "--resolution",
                rrslam::Format("%g", o.resolution)},
               o.work / "grid.txt");
  if (run.exit_code != 0) {
    report->Add(s, {"exit code", static_cast<double>(run.exit_code), "", "0", false});
    return;
  }
  report->Note(s, "rrslam-render: " + run.stdout_text.substr(0, run.stdout_text.find('\n')));
  const long long over = Find(run.stdout_text, "; ([0-9]+) of [0-9]+ keyframe cameras");
  const long long cameras = Find(run.stdout_text, "; [0-9]+ of ([0-9]+) keyframe cameras");
  report->Add(s, {"wall time", run.wall_s, "s", "-", true});
  report->Add(s, {"keyframe cameras over free cells", 100.0 * over / std::max(1LL, cameras), "%",
                  "report", true});
  report->Add(s, {"free cells", static_cast<double>(Find(run.stdout_text, "m: ([0-9]+) free")), "",
                  "-", true});
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  CLI::App app("bench_octomap: rrslam-render octomap and grid on a real map");
  app.add_option("--render", o.render)->required();
  app.add_option("--map", o.map)->required();
  app.add_option("--sequence", o.sequence)->required();
  app.add_option("--work", o.work)->required();
  app.add_option("--runs", o.runs);
  app.add_option("--resolution", o.resolution);
  app.add_option("--machine", o.machine)->required();
  app.add_option("--out", o.out)->required();
  CLI11_PARSE(app, argc, argv);
  fs::create_directories(o.work);
  Report report;
  std::string nodes;
  Integration(o, &report, &nodes);
  ReadByOctomapTools(o, nodes, &report);
  Grid(o, &report);
  rrslam::bench::WriteGoalResults(
      o.out, "Issue 32: rrslam-render octomap and grid of " + o.map.string(),
      "make bench-octomap BENCH_OCTOMAP_MAP=" + o.map.string(), o.machine, report);
  return report.AllPass() ? 0 : 1;
}
