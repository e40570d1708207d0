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
// And, with --synth-vocab, the atlas (online merge) on rrslam-synth's room:
// the sweep mapped, then the turn (starting off the map, turning onto it)
// run on that map in batch and realtime mode: the merge's delay after the
// first frame whose true view overlaps the map, the ATE of every frame in
// the loaded map's frame, frames lost after the merge; and a session that
// never meets the map (the turn's first 100 frames): frames lost after its
// new map started.
// Kills (--kills N each): rrslam-mapstore merge of the first real sequence's
// maps, its --out an existing map, killed (SIGKILL) at moments uniform over
// its run; and the turn session loading and saving one map file
// (--load-map M --save-map M), killed at moments uniform over its merge
// (from its "merging" line to 1.2 x the merge's time). The previous map must
// be intact every time, or the new one complete.
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
#include "bench/common/save_kills.h"
#include "common/atomic_file.h"
#include "common/dataset.h"
#include "common/trajectory.h"
#include "stages/eval/ate.h"
#include "stages/mapstore/map_file.h"
#include "stages/mapstore/map_join.h"

namespace {

namespace fs = std::filesystem;
using nlohmann::ordered_json;
using rrslam::bench::KillClock;
using rrslam::bench::Quote;
using rrslam::bench::Report;
using rrslam::bench::Run;
using rrslam::bench::SaveOverFile;

struct Options {
  fs::path bin, runs;
  std::vector<std::string> real_names;
  std::vector<fs::path> real_dirs, real_settings, real_vocabs, real_features;
  fs::path synth_vocab;  // The atlas's synthetic sessions; empty: not measured.
  int frames = 150, sessions = 5, kills = 10;
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
  app->add_option("--synth-vocab", o->synth_vocab,
                  "Vocabulary for the atlas's synthetic sessions (rendered here); none: skipped");
  app->add_option("--frames", o->frames, "Frames of each session, from the first")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  app->add_option("--sessions", o->sessions, "Restore-mapping sessions after the mapping run")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  app->add_option("--kills", o->kills, "SIGKILLs during each merge (0: none)")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  app->add_option("--machine", o->machine, "Machine description line");
  app->add_option("--command", o->command, "The command that made this result, for its header")
      ->capture_default_str();
  app->add_option("--out", o->out_prefix, "Result files prefix (writes .txt and .json)")
      ->required();
}

std::string Short(double x) {
  std::ostringstream s;
  s.precision(x < 10 ? 3 : 4);
  s << x;
  return s.str();
}

struct Sequence {
  std::string name;
  fs::path dir, settings, vocab, features;
};

// rrslam-track on `seq` into `out` (from its features file, or its images
// when it has none), with `extra` flags.
std::string TrackCommand(const Options& o, const Sequence& seq, const fs::path& out,
                         const std::string& extra) {
  return (o.bin / "rrslam-track").string() + " --quiet --sequence " + Quote(seq.dir) +
         " --settings " + Quote(seq.settings) + " --vocab " + Quote(seq.vocab) +
         (seq.features.empty() ? "" : " --features " + Quote(seq.features)) + " --out " +
         Quote(out) + " " + extra;
}

// A sequence rrslam-synth rendered into dir/name, tracked from its images
// with the atlas's vocabulary.
Sequence SynthSequence(const Options& o, const fs::path& dir, const std::string& name) {
  return {name, dir / name, dir / name / "settings.yaml", o.synth_vocab, {}};
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
  std::string extra = "--max-frames " + std::to_string(o.frames) + " --save-map " + Quote(map);
  if (i > 0) extra += " --load-map " + Quote(dir / ("map-" + std::to_string(i - 1) + ".rrm"));
  const std::string command = TrackCommand(o, seq, out, extra);
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

// The same two parts merged online (the atlas): the last 40% run on the
// first 30%'s map (restore mapping); where it does not relocalize within
// --new-map-after it starts a new map, merged when it meets the loaded one.
bool MeasureOnlineMerge(const Options& o, const Sequence& seq, const fs::path& dir,
                        size_t second_start, const rrslam::Trajectory& gt, Report* report) {
  if (Run(TrackCommand(o, seq, dir / "online",
                       "--first-frame " + std::to_string(second_start) + " --load-map " +
                           Quote(dir / "a.rrm"))) != 0) {
    return false;
  }
  std::ifstream in(dir / "online" / "run.json");
  const nlohmann::json run = nlohmann::json::parse(in);
  const nlohmann::json& atlas = run.at("atlas");
  const std::string s = seq.name + ", frames " + std::to_string(second_start) +
                        "- started on the map of the first 30% (online merge)";
  const nlohmann::json& merges = atlas.at("merges");
  report->Note(s, "new map started: " +
                      std::string(atlas.at("maps_started").get<int>() > 0
                                      ? "after " +
                                            Short(atlas.at("new_map_timestamp").get<double>() -
                                                  gt.front().timestamp) +
                                            " s of the sequence's time"
                                      : "no (relocalized at once)"));
  const rrslam::AteAlignment alignment = rrslam::ComputeAteAlignment(
      gt, rrslam::ReadTumTrajectory(dir / "a" / "CameraTrajectory.txt"));
  const rrslam::Trajectory est = rrslam::ReadTumTrajectory(dir / "online" / "CameraTrajectory.txt");
  const double ate = rrslam::EvaluateAte(gt, est, alignment).error.rmse;
  // Lost frames after the merge, or without one after the first pose in the
  // loaded map.
  const double merged_at =
      merges.empty() ? est.front().timestamp : merges.at(0).at("timestamp").get<double>();
  int lost_after = 0;
  for (const auto& t : run.at("lost_timestamps")) lost_after += t.get<double>() > merged_at;
  if (!merges.empty()) {
    const nlohmann::json& m = merges.at(0);
    report->Note(s, "merged at " + Short(merged_at - gt.front().timestamp) + " s (" +
                        std::to_string(m.at("keyframes_matched").get<int>()) + " of " +
                        std::to_string(m.at("keyframes_checked").get<int>()) +
                        " keyframes matched, " + std::to_string(m.at("points_fused").get<int>()) +
                        " points fused, " + Short(m.at("ms").get<double>()) + " ms)");
  }
  report->Add(s, {"frames tracked", run.at("counts").at("tracked").get<double>(),
                  "of " + std::to_string(run.at("counts").at("frames").get<int>()), "-", true});
  report->Add(s,
              {merges.empty() ? "frames lost after the first pose" : "frames lost after the merge",
               double(lost_after), "frames", "-", true});
  report->Add(s, {"ATE in the loaded map's frame, tracked frames", ate * 100, "cm", "-", true});
  return true;
}

// The offline merge's folder of one sequence.
fs::path MergeDir(const Options& o, const Sequence& seq) { return o.runs / (seq.name + "-merge"); }

// The offline merge of one sequence, into its section of the report.
bool MeasureOfflineMerge(const Options& o, const Sequence& seq, Report* report) {
  const rrslam::RgbdSequence frames = rrslam::RgbdSequence::Open(seq.dir);
  const size_t n = frames.size(), first_end = n * 3 / 10, second_start = n * 6 / 10;
  const fs::path dir = MergeDir(o, seq);
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
  return MeasureOnlineMerge(o, seq, dir, second_start, gt, report);
}

// Kills at moments uniform in [from_s, to_s] after `clock`'s origin of
// `save` (its new_bytes and original set here: a run not killed first);
// into section `s`.
void MeasureKills(const Options& o, SaveOverFile save, double from_s, double to_s, KillClock clock,
                  const std::string& marker, const std::string& note, const std::string& s,
                  Report* report) {
  for (const std::string& name : rrslam::bench::TemporaryFilesOf(save.target)) {
    fs::remove(save.target.parent_path() / name);
  }
  fs::copy_file(save.original, save.target, fs::copy_options::overwrite_existing);
  save.old_bytes = rrslam::ReadFileToString(save.target);
  const rrslam::bench::KillCounts counts =
      rrslam::bench::KillDuringSaves(save, from_s, to_s, clock, o.kills, marker);
  rrslam::bench::AddKillCounts(counts, o.kills, note, s, report);
}

// rrslam-mapstore merge of a.rrm and b.rrm in `dir` over a copy of a.rrm,
// killed at moments uniform over a run's time (1.1 x an unkilled run's).
void MeasureKillsDuringOfflineMerge(const Options& o, const Sequence& seq, const fs::path& dir,
                                    Report* report) {
  SaveOverFile save;
  save.original = dir / "a.rrm";
  save.target = dir / "killed.rrm";
  save.argv = {(o.bin / "rrslam-mapstore").string(),
               "--quiet",
               "merge",
               (dir / "a.rrm").string(),
               (dir / "b.rrm").string(),
               "--vocab",
               seq.vocab.string(),
               "--settings",
               seq.settings.string(),
               "--out",
               save.target.string()};
  fs::copy_file(save.original, save.target, fs::copy_options::overwrite_existing);
  const rrslam::bench::SaveRun unkilled =
      rrslam::bench::RunWatchingSave(save.argv, save.target, std::nullopt);
  save.new_bytes = rrslam::ReadFileToString(save.target);
  const double run_s = unkilled.end_ms.value_or(0) / 1000;
  MeasureKills(
      o, save, 0, 1.1 * run_s, KillClock::kRunStart, "",
      "run of " + Short(run_s) + " s (save from " + Short(unkilled.save_ms.value_or(-1) / 1000) +
          " s); kills uniform up to 1.1 x the run's time",
      "kill -9 during rrslam-mapstore merge (" + seq.name + ", --out an existing map)", report);
}

// The atlas's synthetic sessions (rrslam-synth's room, 640 x 480, seed 1):
// the sweep (looking north) mapped, then the turn (looking south, turning
// north onto the sweep's view) started on that map.
struct AtlasRun {
  nlohmann::json run;        // run.json
  double ate_m = 0;          // In the loaded map's frame, every tracked frame.
  int lost_after_new = 0;    // Frames lost after the new map started.
  int lost_after_merge = 0;  // ... after the merge.
};

// The first frame of `truth` whose true view holds at least 50 of `map`'s
// points by ORB-SLAM2's frustum test (in the image, depth > 0, within the
// point's scale distances, at most 60 degrees from its mean viewing
// direction); T_gt_map moves the map into the ground truth's world. The
// timestamp, or -1.
double FirstOverlappingFrame(const rrslam::MapData& map, const rrslam::Rigid3d& T_gt_map,
                             const rrslam::Trajectory& truth) {
  for (const rrslam::StampedPose& pose : truth) {
    const rrslam::Rigid3d T_cam_map = pose.T_world_cam.Inverse() * T_gt_map;
    const Eigen::Vector3d centre = T_cam_map.Inverse().translation;
    int seen = 0;
    for (const rrslam::MapPointRecord& p : map.map_points) {
      const Eigen::Vector3d x(p.position[0], p.position[1], p.position[2]);
      const Eigen::Vector3d c = T_cam_map * x;
      if (c.z() <= 0) continue;
      const double u = map.camera.fx * c.x() / c.z() + map.camera.cx;
      const double v = map.camera.fy * c.y() / c.z() + map.camera.cy;
      const double distance = (x - centre).norm();
      const Eigen::Vector3d normal(p.normal[0], p.normal[1], p.normal[2]);
      if (u < 0 || v < 0 || u >= map.camera.width || v >= map.camera.height ||
          distance < 0.8 * p.min_distance || distance > 1.2 * p.max_distance ||
          (x - centre).dot(normal) < 0.5 * distance) {
        continue;
      }
      if (++seen >= 50) return pose.timestamp;
    }
  }
  return -1;
}

bool RunAtlasSession(const Options& o, const fs::path& dir, const std::string& name,
                     const std::string& extra, const rrslam::AteAlignment& alignment,
                     const rrslam::Trajectory& truth, AtlasRun* result) {
  const fs::path out = dir / name;
  if (Run(TrackCommand(o, SynthSequence(o, dir, "turn"), out,
                       "--load-map " + Quote(dir / "sweep.rrm") + " " + extra)) != 0) {
    return false;
  }
  std::ifstream in(out / "run.json");
  result->run = nlohmann::json::parse(in);
  const nlohmann::json& atlas = result->run.at("atlas");
  const double new_map = atlas.value("new_map_timestamp", 1e300);
  const double merged =
      atlas.at("merges").empty() ? 1e300 : atlas.at("merges").at(0).at("timestamp").get<double>();
  for (const auto& t : result->run.at("lost_timestamps")) {
    result->lost_after_new += t.get<double>() > new_map;
    result->lost_after_merge += t.get<double>() > merged;
  }
  if (!atlas.at("merges").empty()) {
    result->ate_m = rrslam::EvaluateAte(
                        truth, rrslam::ReadTumTrajectory(out / "CameraTrajectory.txt"), alignment)
                        .error.rmse;
  }
  return true;
}

void ReportMergedSession(const std::string& s, const std::string& mode, const AtlasRun& r,
                         double first_overlap, Report* report) {
  const nlohmann::json& atlas = r.run.at("atlas");
  if (atlas.at("merges").empty()) {
    report->Add(s, {mode + ": merged", 0, "merges", ">= 1", false});
    return;
  }
  const nlohmann::json& m = atlas.at("merges").at(0);
  const double delay = m.at("timestamp").get<double>() - first_overlap;
  report->Add(s, {mode + ": merge after the first overlapping frame", delay, "s camera time",
                  "<= 1 s", delay <= 1.0});
  report->Note(
      s, mode + ": new map after " + Short(atlas.at("new_map_timestamp").get<double>()) +
             " s; first keyframe matched at " + Short(m.at("first_match_timestamp").get<double>()) +
             " s, merged at " + Short(m.at("timestamp").get<double>()) + " s (" +
             std::to_string(m.at("keyframes_matched").get<int>()) + " of " +
             std::to_string(m.at("keyframes_checked").get<int>()) + " keyframes matched, " +
             std::to_string(m.at("points_fused").get<int>()) + " points fused); the merge took " +
             Short(m.at("ms").get<double>()) + " ms, a check " +
             Short(atlas.at("check").at("median_ms").get<double>()) + " ms median");
  report->Add(s, {mode + ": ATE in the loaded map's frame, every tracked frame", r.ate_m * 100,
                  "cm", "<= 2 cm", r.ate_m <= 0.02});
  report->Add(s, {mode + ": frames lost after the merge", double(r.lost_after_merge), "frames", "0",
                  r.lost_after_merge == 0});
}

// The turn session loading and saving one map file (a copy of the sweep's),
// killed at moments uniform over its merge: from its "merging" line to 1.2 x
// the merge's time in an unkilled run (batch mode: the same merge each run).
void MeasureKillsDuringOnlineMerge(const Options& o, const fs::path& dir, Report* report) {
  const Sequence turn = SynthSequence(o, dir, "turn");
  SaveOverFile save;
  save.original = dir / "sweep.rrm";
  save.target = dir / "killed.rrm";
  save.argv = {(o.bin / "rrslam-track").string(),
               "--sequence",
               turn.dir.string(),
               "--settings",
               turn.settings.string(),
               "--vocab",
               turn.vocab.string(),
               "--out",
               (dir / "killed-run").string(),
               "--load-map",
               save.target.string(),
               "--save-map",
               save.target.string()};
  const std::string marker = "track: merging the new map";
  fs::copy_file(save.original, save.target, fs::copy_options::overwrite_existing);
  const rrslam::bench::SaveRun unkilled = rrslam::bench::RunWatchingSave(
      save.argv, save.target, std::nullopt, KillClock::kSaveStart, marker);
  save.new_bytes = rrslam::ReadFileToString(save.target);
  std::ifstream in(dir / "killed-run" / "run.json");
  const nlohmann::json merges = nlohmann::json::parse(in).at("atlas").at("merges");
  const std::string s = "kill -9 during the online merge (turn session, --load-map M --save-map M)";
  if (!unkilled.marker_ms || merges.empty()) {
    report->Add(s, {"merged", 0, "merges", ">= 1", false});
    return;
  }
  const double merge_s = merges.at(0).at("ms").get<double>() / 1000;
  MeasureKills(o, save, 0, 1.2 * merge_s, KillClock::kMarker, marker,
               "merge from " + Short(*unkilled.marker_ms / 1000) + " s for " +
                   Short(merge_s * 1000) + " ms, save from " +
                   Short(unkilled.save_ms.value_or(-1) / 1000) + " s, end at " +
                   Short(unkilled.end_ms.value_or(-1) / 1000) +
                   " s; kills uniform from the merge's first line to 1.2 x its time",
               s, report);
}

// The atlas (online merge) on the synthetic room, into its section.
bool MeasureAtlas(const Options& o, Report* report) {
  const fs::path dir = o.runs / "synth-atlas";
  fs::create_directories(dir);
  const std::string synth = (o.bin / "rrslam-synth").string() + " --quiet --seed 1 --out ";
  for (const auto& [name, frames] : {std::pair<std::string, int>{"sweep", 300}, {"turn", 720}}) {
    if (fs::exists(dir / name / "synth.json")) continue;
    if (Run(synth + Quote(dir / name) + " --trajectory " + name + " --frames " +
            std::to_string(frames)) != 0) {
      return false;
    }
  }
  if (Run(TrackCommand(o, SynthSequence(o, dir, "sweep"), dir / "mapping",
                       "--save-map " + Quote(dir / "sweep.rrm"))) != 0) {
    return false;
  }
  // The map's frame in the ground truth's world, from the mapping run.
  const rrslam::AteAlignment alignment = rrslam::ComputeAteAlignment(
      rrslam::ReadTumTrajectory(dir / "sweep" / "groundtruth.txt"),
      rrslam::ReadTumTrajectory(dir / "mapping" / "CameraTrajectory.txt"));
  const rrslam::Trajectory truth = rrslam::ReadTumTrajectory(dir / "turn" / "groundtruth.txt");
  const double first_overlap =
      FirstOverlappingFrame(rrslam::ReadMapFile(dir / "sweep.rrm"), alignment.T_gt_est, truth);
  AtlasRun batch, realtime, never;
  if (!RunAtlasSession(o, dir, "batch", "--save-map " + Quote(dir / "merged.rrm"), alignment, truth,
                       &batch) ||
      !RunAtlasSession(o, dir, "realtime", "--mode realtime", alignment, truth, &realtime) ||
      !RunAtlasSession(o, dir, "never", "--max-frames 100", alignment, truth, &never)) {
    return false;
  }
  const std::string s = "synthetic room: a session off the sweep's map turning onto it (atlas)";
  report->Note(s,
               "first frame of the turn whose true view holds >= 50 of the map's points "
               "(ORB-SLAM2's frustum test): " +
                   Short(first_overlap) + " s");
  ReportMergedSession(s, "batch", batch, first_overlap, report);
  ReportMergedSession(s, "realtime", realtime, first_overlap, report);
  report->Add(s, {"never meets the map (frames 0-99): frames lost after the new map",
                  double(never.lost_after_new), "frames", "0", never.lost_after_new == 0});
  if (o.kills > 0) MeasureKillsDuringOnlineMerge(o, dir, report);
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
    if (!MeasureOfflineMerge(o, seq, &report)) {
      failed = true;
    } else if (q == 0 && o.kills > 0) {
      MeasureKillsDuringOfflineMerge(o, seq, MergeDir(o, seq), &report);
    }
  }
  if (!o.synth_vocab.empty() && !MeasureAtlas(o, &report)) failed = true;
  // A part whose runs failed left its figures out: the summary must say so.
  report.Add("runs", {"parts whose runs failed (their figures missing)", failed ? 1.0 : 0.0, "",
                      "0", !failed});
  rrslam::bench::WriteGoalResults(
      o.out_prefix, "bench-lifelong: maps kept over many sessions, against the goals of issue 31",
      o.command, o.machine, report);
  return failed ? 1 : 0;
}
