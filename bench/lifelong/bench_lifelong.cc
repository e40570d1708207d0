// bench_lifelong: many sessions on one map (issue 31). For each real
// sequence:
//  - identical sessions: its first --frames frames mapped and saved, then
//    --sessions restore-mapping runs on the same frames, each on the map the
//    last one saved; what each run.json says about the loaded map is the
//    figure;
//  - offline merge: its first 30% and last 40% of frames mapped separately
//    (two world frames), merged by rrslam-mapstore merge; the merged map's
//    keyframes against the ground truth under one rigid alignment, beside
//    the keyframes of one run over the whole sequence; then the middle 30%
//    localized in the merged map (--localization-only).
// Usage: see --help; `make bench-lifelong` gives every option.
#include <CLI/CLI.hpp>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "bench/common/bench_report.h"
#include "common/atomic_file.h"
#include "common/dataset.h"
#include "common/trajectory.h"
#include "stages/eval/ate.h"
#include "stages/mapstore/map_file.h"
#include "stages/mapstore/map_join.h"

namespace {

namespace fs = std::filesystem;
using nlohmann::ordered_json;
using rrslam::bench::Quote;
using rrslam::bench::Report;
using rrslam::bench::Run;

struct Options {
  fs::path bin, runs;
  std::vector<std::string> real_names;
  std::vector<fs::path> real_dirs, real_settings, real_vocabs, real_features;
  int frames = 150, sessions = 5;
  std::string machine, out_prefix, command = "make bench-lifelong";
};

void BindOptions(CLI::App* app, Options* o) {
  app->add_option("--bin", o->bin, "Folder of the rrslam-* executables")->required();
  app->add_option("--runs", o->runs, "Folder for the runs' outputs")->required();
  app->add_option("--real", o->real_names, "Name of a real sequence (repeat per sequence)");
  app->add_option("--real-dir", o->real_dirs, "Its folder");
  app->add_option("--real-settings", o->real_settings, "Its settings YAML");
  app->add_option("--real-vocab", o->real_vocabs, "Its binary vocabulary");
  app->add_option("--real-features", o->real_features, "Its features file (rrslam-extract)");
  app->add_option("--frames", o->frames, "Frames of each session, from the first")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  app->add_option("--sessions", o->sessions, "Restore-mapping sessions after the mapping run")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  app->add_option("--machine", o->machine, "Machine description line");
  app->add_option("--command", o->command, "The command that made this result, for its header")
      ->capture_default_str();
  app->add_option("--out", o->out_prefix, "Result files prefix (writes .txt and .json)")
      ->required();
}

struct Sequence {
  std::string name;
  fs::path dir, settings, vocab, features;
};

std::string TrackCommand(const Options& o, const Sequence& seq, const fs::path& out,
                         const std::string& extra) {
  return (o.bin / "rrslam-track").string() + " --quiet --sequence " + Quote(seq.dir) +
         " --settings " + Quote(seq.settings) + " --vocab " + Quote(seq.vocab) + " --features " +
         Quote(seq.features) + " --out " + Quote(out) + " " + extra;
}

// One restore-mapping session's run.json "map" object, or the mapping run's.
struct Session {
  int keyframes = 0;  // After the session.
  int points = 0;
  int loaded_points = 0;
  int changed = 0;  // Loaded points culled as changed.
};

nlohmann::json ReadMapSummary(const fs::path& run_json) {
  std::ifstream in(run_json);
  return nlohmann::json::parse(in).at("map");
}

// Runs session `i` (0 = the mapping run) of `seq`; false when it failed.
bool RunSession(const Options& o, const Sequence& seq, int i, Session* session) {
  const fs::path dir = o.runs / seq.name;
  const fs::path out = dir / ("session-" + std::to_string(i));
  const fs::path map = dir / ("map-" + std::to_string(i) + ".rrm");
  std::string command = (o.bin / "rrslam-track").string() + " --quiet --sequence " +
                        Quote(seq.dir) + " --settings " + Quote(seq.settings) + " --vocab " +
                        Quote(seq.vocab) + " --features " + Quote(seq.features) + " --max-frames " +
                        std::to_string(o.frames) + " --out " + Quote(out) + " --save-map " +
                        Quote(map);
  if (i > 0) command += " --load-map " + Quote(dir / ("map-" + std::to_string(i - 1) + ".rrm"));
  if (Run(command) != 0) return false;
  const nlohmann::json m = ReadMapSummary(out / "run.json");
  const int loaded_kf = m.value("keyframes_loaded", 0),
            loaded_pts = m.value("map_points_loaded", 0);
  session->keyframes =
      loaded_kf + m.at("keyframes_added").get<int>() - m.at("keyframes_culled").get<int>();
  // map_points_culled: every loaded point gone, those culled as changed too.
  session->points =
      loaded_pts + m.at("map_points_added").get<int>() - m.value("map_points_culled", 0);
  session->loaded_points = loaded_pts;
  session->changed = m.value("changed_points_culled", 0);
  return true;
}

// The identical sessions of one sequence, into its section of the report.
bool MeasureIdenticalSessions(const Options& o, const Sequence& seq, Report* report) {
  fs::remove_all(o.runs / seq.name);
  fs::create_directories(o.runs / seq.name);
  std::vector<Session> sessions(o.sessions + 1);
  for (int i = 0; i <= o.sessions; ++i) {
    if (!RunSession(o, seq, i, &sessions[i])) return false;
  }
  const std::string s =
      seq.name + ", identical sessions of frames 0-" + std::to_string(o.frames - 1);
  report->Add(s, {"mapping run: keyframes", double(sessions[0].keyframes), "", "-", true});
  report->Add(s, {"mapping run: points", double(sessions[0].points), "", "-", true});
  for (int i = 1; i <= o.sessions; ++i) {
    const Session& x = sessions[i];
    const std::string n = "session " + std::to_string(i) + ": ";
    const double percent = 100.0 * x.changed / std::max(1, x.loaded_points);
    report->Add(s,
                {n + "loaded points culled as changed", percent,
                 "% (" + std::to_string(x.changed) + " of " + std::to_string(x.loaded_points) + ")",
                 "<= 1 %", percent <= 1.0});
    report->Add(s, {n + "keyframes, points after", double(x.keyframes),
                    "kf, " + std::to_string(x.points) + " points", "-", true});
  }
  const double growth = double(sessions.back().keyframes) / std::max(1, sessions[1].keyframes);
  report->Add(s, {"keyframes after the last session / after the first", growth, "x", "<= 1.1",
                  growth <= 1.1});
  return true;
}

// The keyframes of a saved map as a trajectory (timestamps, T_world_cam).
rrslam::Trajectory KeyFramesOf(const fs::path& map) {
  rrslam::Trajectory t;
  for (const rrslam::KeyFrameRecord& kf : rrslam::ReadMapFile(map).keyframes) {
    t.push_back({kf.timestamp, rrslam::RigidOf(kf.T_cam_world).Inverse()});
  }
  return t;
}

double KeyFrameAte(const fs::path& map_or_trajectory, const rrslam::Trajectory& gt) {
  const rrslam::Trajectory est = map_or_trajectory.extension() == ".rrm"
                                     ? KeyFramesOf(map_or_trajectory)
                                     : rrslam::ReadTumTrajectory(map_or_trajectory);
  return rrslam::ComputeAte(gt, est).error.rmse;
}

// The offline merge of one sequence, into its section of the report.
bool MeasureOfflineMerge(const Options& o, const Sequence& seq, Report* report) {
  const rrslam::RgbdSequence frames = rrslam::RgbdSequence::Open(seq.dir);
  const size_t n = frames.size(), first_end = n * 3 / 10, second_start = n * 6 / 10;
  const fs::path dir = o.runs / (seq.name + "-merge");
  fs::remove_all(dir);
  fs::create_directories(dir);
  const fs::path a = dir / "a.rrm", b = dir / "b.rrm", merged = dir / "merged.rrm";
  const std::string first = "--max-frames " + std::to_string(first_end);
  const std::string middle = "--first-frame " + std::to_string(first_end) + " --max-frames " +
                             std::to_string(second_start - first_end);
  if (Run(TrackCommand(o, seq, dir / "a", first + " --save-map " + Quote(a))) != 0 ||
      Run(TrackCommand(
          o, seq, dir / "b",
          "--first-frame " + std::to_string(second_start) + " --save-map " + Quote(b))) != 0 ||
      Run(TrackCommand(o, seq, dir / "whole", "")) != 0 ||
      Run((o.bin / "rrslam-mapstore").string() + " --quiet merge " + Quote(a) + " " + Quote(b) +
          " --vocab " + Quote(seq.vocab) + " --settings " + Quote(seq.settings) + " --out " +
          Quote(merged) + " > " + Quote(dir / "merge.txt")) != 0 ||
      Run(TrackCommand(o, seq, dir / "middle",
                       middle + " --load-map " + Quote(merged) + " --localization-only")) != 0) {
    return false;
  }
  const std::string s = seq.name + ", offline merge of frames 0-" + std::to_string(first_end - 1) +
                        " and " + std::to_string(second_start) + "-" + std::to_string(n - 1);
  const rrslam::Trajectory gt = *frames.groundtruth();
  const double merged_ate = KeyFrameAte(merged, gt);
  const double whole_ate = KeyFrameAte(dir / "whole" / "KeyFrameTrajectory.txt", gt);
  report->Add(
      s, {"merged map's keyframes: ATE RMSE, one alignment", merged_ate * 100, "cm", "-", true});
  report->Add(s, {"one run over every frame: keyframe ATE RMSE", whole_ate * 100, "cm", "-", true});
  report->Add(s, {"  ratio", merged_ate / whole_ate, "x", "<= 1.2", merged_ate <= 1.2 * whole_ate});
  std::ifstream in(dir / "middle" / "run.json");
  const nlohmann::json counts = nlohmann::json::parse(in).at("counts");
  const double tracked =
      100.0 * counts.at("tracked").get<double>() / std::max(1.0, counts.at("frames").get<double>());
  report->Add(s, {"frames " + std::to_string(first_end) + "-" + std::to_string(second_start - 1) +
                      " localized in the merged map",
                  tracked, "%", ">= 99 %", tracked >= 99.0});
  std::ifstream merge_text(dir / "merge.txt");
  for (std::string line; std::getline(merge_text, line);) report->Note(s, line);
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app("Measures maps kept over many restore-mapping sessions (issue 31).");
  Options o;
  BindOptions(&app, &o);
  CLI11_PARSE(app, argc, argv);
  const size_t n = o.real_names.size();
  if (o.real_dirs.size() != n || o.real_settings.size() != n || o.real_vocabs.size() != n ||
      o.real_features.size() != n) {
    std::cerr << "bench_lifelong: give every --real-* option once per --real\n";
    return 64;
  }
  Report report;
  bool failed = false;
  for (size_t q = 0; q < n; ++q) {
    const Sequence seq{o.real_names[q], o.real_dirs[q], o.real_settings[q], o.real_vocabs[q],
                       o.real_features[q]};
    if (!MeasureIdenticalSessions(o, seq, &report)) failed = true;
    if (!MeasureOfflineMerge(o, seq, &report)) failed = true;
  }
  rrslam::bench::WriteGoalResults(
      o.out_prefix, "bench-lifelong: maps kept over many sessions, against the goals of issue 31",
      o.command, o.machine, report);
  return failed ? 1 : 0;
}
