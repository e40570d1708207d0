// bench_scale: how maps scale with keyframes (`make bench-scale`, issue 35),
// on maps composed from a real one (stages/mapstore/map_compose.h: copies of
// the map on a 20 m grid, descriptors perturbed by --flipped-bits, bags of
// words recomputed with the map's vocabulary).
//
//   bench_scale --map MAP --vocab VOC --mapstore BIN --work DIR
//               [--sizes 1000,3000,10000] [--flipped-bits 64] --machine TEXT
//               --out PREFIX [--track BIN --sequence SEQ --settings YAML
//               [--starts 3] [--first-frame 500] [--start-stride 100]
//               [--frames 100]] [--synth BIN] [--keep]
// For each size (keyframes, rounded up to whole copies): composes the map,
// writes it (save time: encode, write, fsync, rename, in process), its file
// size and bytes per keyframe, loads it in process (ReadMapFile: every
// checksum and relation; median of 3), and runs `BIN verify` as a child
// process three times (the whole process to a loaded, verified map: median
// wall time and the largest peak memory). With --track, cold starts of `rrslam-track --load-map
// --localization-only` on the base map and on each composed map (first pose
// after process start, every relocalization attempt, tracking median, peak
// memory; copy 0 of a composed map is the base map, so the frames relocalize
// there), and one run mapping on it (restore mapping, --mapping-frames
// frames: local mapping's median per keyframe), each run on a composed map
// just after the same run on the base map; then, in process, relocalization
// attempts on every 10th of 500 frames (relocalization_sweep.h). Goals at 10k keyframes (issue 35):
// load
// <= 1.5 s whole process, peak memory <= 2x the file size, save <= 2 s,
// verify <= 1 s, first pose <= 2 s, relocalization attempt p95 <= 30 ms (in
// process), tracking median <= 1.2x the base map's, local mapping <= 1.5x
// the base map's (of the runs alternated with them); file size per keyframe
// no larger than ~125 kB. With --synth, revisits: rrslam-synth's standard room,
// three laps of its loop (19 s each, the camera turned once around per lap;
// rendered once into --work), and with --replay a real sequence whose frames
// come twice, each mapped by rrslam-track with --vocab, with the default
// keyframe rule and with --new-view-fraction 0.15; the keyframes left at the
// end are counted by the pass whose frame made them, and the later passes
// together may add at most 10% of the first's (issue 35). With --track, in
// process, on every map loop closing's essential graph after a made-up loop,
// and on each map of at most --global-ba-max-keyframes keyframes its global
// BA, each on a thread of its own while a camera is localized in the map at
// 30 Hz (loop_step_while_tracking.h): the step's time and the tracking times
// before and during it (goal at 3k keyframes and more: tracking p95 during
// the step within 1.5x of before it). With --synth and
// --building-frames, the building's tour (rrslam-synth --scene building
// --trajectory tour) mapped in one run: keyframes, loops, ATE, timings and
// the saved map's size.
// Writes PREFIX.txt and PREFIX.json, and the curves as PREFIX-time.png,
// PREFIX-memory.png and (with --track) PREFIX-track.png, PREFIX-global-ba.png
// and PREFIX-global-ba-tracking.png.
#include <CLI/CLI.hpp>
#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <numeric>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "bench/common/bench_report.h"
#include "bench/scale/loop_step_while_tracking.h"
#include "bench/scale/relocalization_sweep.h"
#include "common/chart.h"
#include "common/clock.h"
#include "common/dataset.h"
#include "common/image_io.h"
#include "common/trajectory.h"
#include "stages/eval/ate.h"
#include "stages/mapstore/map_compose.h"
#include "stages/mapstore/map_file.h"
#include "stages/synth/building.h"
#include "stages/synth/synth.h"
#include "stages/vocab/vocabulary.h"

namespace {

namespace fs = std::filesystem;
using rrslam::bench::ChildRun;
using rrslam::bench::Median;
using rrslam::bench::Percentile;
using rrslam::bench::Report;
using rrslam::bench::RunChild;

struct Options {
  fs::path map, vocab, mapstore, work;
  std::vector<int> sizes = {1000, 3000, 10000};
  int flipped_bits = rrslam::ComposeOptions{}.flipped_bits;
  std::string machine, out;
  bool keep = false;  // Keep the composed maps in `work` (else each is removed once measured).
  // Cold starts on each map (none without --track): rrslam-track
  // --load-map --localization-only from frame first_frame + i * start_stride
  // of `sequence`, `frames` frames each; the restore-mapping runs from
  // first_frame, `mapping_frames` frames (300 of the kitchen after its map's
  // 500 add 5 keyframes to it, where 100 added one: local mapping's median
  // was one keyframe's time).
  fs::path track, sequence, settings;
  int starts = 3, first_frame = 500, start_stride = 100, frames = 100, mapping_frames = 300;
  fs::path synth;   // rrslam-synth, for the revisits (none without it).
  fs::path replay;  // A sequence of --settings whose frames come twice (revisits).
  // Global BA while tracking (with --track) on maps of at most this many keyframes.
  int global_ba_max_keyframes = 3100;
  int building_frames = 6675;  // Of the building's tour (with --synth; 0: none).
};

// One size's figures, for the plots.
struct Row {
  double keyframes = 0;
  double save_s = 0, load_s = 0, verify_s = 0;  // Seconds.
  double file_mb = 0, peak_mb = 0;              // 10^6 bytes.
  double first_pose_s = 0;                      // Median over the cold starts.
  double relocalization_p95_ms = 0, tracking_median_ms = 0, local_mapping_ms = 0;
  double global_ba_s = 0, essential_graph_s = 0;  // 0: not measured.
  double ba_tracking_p95_before_ms = 0, ba_tracking_p95_during_ms = 0;
  double eg_tracking_p95_before_ms = 0, eg_tracking_p95_during_ms = 0;
};

// What the cold starts on one map measured.
struct ColdStarts {
  std::vector<double> first_pose_s, map_load_s, tracking_median_ms, peak_mb;
  std::vector<double> relocalization_ms;  // Every attempt of every start, index waits excluded.
  std::vector<double> index_ms;           // The map-point index's build, per start.
  std::vector<double> index_wait_ms;      // Attempts' waits for it (or rebuilds), when any.
  int tracked = 0, lost = 0, failed = 0;  // Frames; runs that did not exit 0.
  double local_mapping_ms = 0;            // Restore mapping: median per keyframe.
  int keyframes_created = 0;              // Added by that run (map.keyframes_added).
  // The same runs on a reference map, each just before this map's (0: none).
  std::vector<double> reference_tracking_median_ms;
  double reference_local_mapping_ms = 0;
};

struct Curve {
  std::string label;
  cv::Scalar colour;                    // BGR.
  std::vector<Eigen::Vector2d> points;  // (keyframes, value).
};

// A line chart of `curves` against keyframe count (both axes from 0), with
// the goal at 10k keyframes as a cross where one is given.
cv::Mat PlotCurves(const std::string& title, const std::string& v_label,
                   const std::vector<Curve>& curves) {
  namespace chart = rrslam::chart;
  cv::Mat image(600, 900, CV_8UC3, chart::kBackground);
  const chart::ChartLayout layout = chart::MakeLayout(image.size());
  Eigen::Vector2d hi(1, 1e-3);
  for (const Curve& c : curves) {
    for (const Eigen::Vector2d& p : c.points) hi = hi.cwiseMax(p);
  }
  const chart::Axes2d axes =
      chart::FitAxes(Eigen::Vector2d::Zero(), hi, layout.area, chart::AxisScale::kEach, 1.1);
  chart::DrawGrid(image, layout, axes);
  std::vector<chart::LegendEntry> legend;
  std::vector<cv::Point2d> occupied;
  for (const Curve& c : curves) {
    if (c.points.empty()) continue;
    std::vector<cv::Point> line;
    for (const Eigen::Vector2d& p : c.points) {
      occupied.push_back(axes(p));
      line.push_back(chart::SubPixel(axes(p)));
      cv::circle(image, line.back(), 4 << chart::kShift, c.colour, cv::FILLED, cv::LINE_AA,
                 chart::kShift);
    }
    cv::polylines(image, line, false, c.colour, layout.line_width, cv::LINE_AA, chart::kShift);
    legend.push_back({c.label, c.colour, layout.line_width});
  }
  chart::DrawFrameAndLabels(image, layout, "keyframes", v_label, title);
  chart::DrawLegend(image, layout, legend, occupied);
  return image;
}

// bench/results/PREFIX-{time,memory}.png: the curves of every size; with
// cold starts, PREFIX-track.png too; with global BA, PREFIX-global-ba.png (a
// chart of its own: its tens of seconds would flatten the load times).
void WritePlots(const std::string& out, const std::vector<Row>& rows, bool cold_starts) {
  Curve save{"save (s)", {40, 40, 200}, {}}, load{"load in process (s)", {200, 120, 40}, {}},
      verify{"verify, whole process (s)", {40, 150, 40}, {}},
      first_pose{"rrslam-track first pose (s)", {160, 40, 160}, {}};
  Curve global_ba{"global BA while tracking (s)", {120, 120, 120}, {}},
      essential_graph{"essential graph while tracking (s)", {200, 120, 40}, {}},
      ba_before{"tracking p95 before global BA (ms)", {40, 150, 40}, {}},
      ba_during{"tracking p95 during global BA (ms)", {40, 40, 200}, {}},
      eg_before{"tracking p95 before essential graph (ms)", {200, 200, 60}, {}},
      eg_during{"tracking p95 during essential graph (ms)", {200, 120, 40}, {}};
  Curve file{"file (MB)", {200, 120, 40}, {}}, peak{"load peak memory (MB)", {40, 40, 200}, {}};
  Curve relocalization{"relocalization attempt p95 (ms)", {40, 40, 200}, {}},
      tracking{"tracking median (ms)", {40, 150, 40}, {}};
  for (const Row& r : rows) {
    save.points.emplace_back(r.keyframes, r.save_s);
    load.points.emplace_back(r.keyframes, r.load_s);
    verify.points.emplace_back(r.keyframes, r.verify_s);
    first_pose.points.emplace_back(r.keyframes, r.first_pose_s);
    if (r.global_ba_s > 0) {
      global_ba.points.emplace_back(r.keyframes, r.global_ba_s);
      ba_before.points.emplace_back(r.keyframes, r.ba_tracking_p95_before_ms);
      ba_during.points.emplace_back(r.keyframes, r.ba_tracking_p95_during_ms);
    }
    if (r.essential_graph_s > 0) {
      essential_graph.points.emplace_back(r.keyframes, r.essential_graph_s);
      eg_before.points.emplace_back(r.keyframes, r.eg_tracking_p95_before_ms);
      eg_during.points.emplace_back(r.keyframes, r.eg_tracking_p95_during_ms);
    }
    file.points.emplace_back(r.keyframes, r.file_mb);
    peak.points.emplace_back(r.keyframes, r.peak_mb);
    relocalization.points.emplace_back(r.keyframes, r.relocalization_p95_ms);
    tracking.points.emplace_back(r.keyframes, r.tracking_median_ms);
  }
  std::vector<Curve> times = {save, load, verify};
  if (cold_starts) times.push_back(first_pose);
  rrslam::WritePng(out + "-time.png",
                   PlotCurves("map file times against keyframes", "seconds", times));
  rrslam::WritePng(out + "-memory.png",
                   PlotCurves("map file and load memory against keyframes", "MB", {file, peak}));
  if (cold_starts) {
    rrslam::WritePng(out + "-track.png", PlotCurves("rrslam-track on the map (localization only)",
                                                    "milliseconds", {relocalization, tracking}));
  }
  if (!global_ba.points.empty() || !essential_graph.points.empty()) {
    rrslam::WritePng(out + "-global-ba.png",
                     PlotCurves("loop closing's optimizations against keyframes", "seconds",
                                {essential_graph, global_ba}));
    rrslam::WritePng(out + "-global-ba-tracking.png",
                     PlotCurves("tracking at 30 Hz before and during loop closing's optimizations",
                                "milliseconds", {ba_before, ba_during, eg_before, eg_during}));
  }
}

double SecondsOf(const std::function<void()>& f) {
  const auto start = rrslam::SteadyClock::now();
  f();
  return rrslam::MillisecondsSince(start) / 1000.0;
}

// One run of rrslam-track on `map` from `first_frame`, localization only
// (`o.frames` frames) or mapping (`o.mapping_frames`): its run.json, or null
// when it failed; its peak memory in `peak_mb`.
std::optional<nlohmann::json> RunTrack(const Options& o, const fs::path& map, int first_frame,
                                       bool localization_only, double* peak_mb) {
  const int frames = localization_only ? o.frames : o.mapping_frames;
  const fs::path out = o.work / "track";
  std::vector<std::string> argv = {o.track.string(), "--quiet",
                                   "--sequence",     o.sequence.string(),
                                   "--settings",     o.settings.string(),
                                   "--vocab",        o.vocab.string(),
                                   "--load-map",     map.string(),
                                   "--first-frame",  std::to_string(first_frame),
                                   "--max-frames",   std::to_string(frames),
                                   "--out",          out.string()};
  if (localization_only) argv.push_back("--localization-only");
  const ChildRun run = RunChild(argv, o.work / "track.txt");
  if (run.exit_code != 0) return std::nullopt;
  *peak_mb = run.max_rss_mb;
  std::ifstream in(out / "run.json");
  return nlohmann::json::parse(in);
}

// Tracking's median per frame in a run.json.
double TrackingMedianMs(const nlohmann::json& run) {
  return run.at("timings").at("tracking").at("median_ms").get<double>();
}

// Local mapping's median per keyframe in a run.json.
double LocalMappingMs(const nlohmann::json& run) {
  return run.at("timings").at("local_mapping").at("median_ms").get<double>();
}

// `o.starts` cold starts of rrslam-track on `map` (localization only), and
// one run mapping on it (restore mapping) from the first start's frame.
// With a `reference` map, each run is preceded by the same run on it, so
// that tracking and local mapping compare with runs of the same minutes:
// this machine's speed drifts by more than the goals' margins between the
// sections of a bench-scale run.
ColdStarts RunColdStarts(const Options& o, const fs::path& map,
                         const fs::path& reference = fs::path()) {
  ColdStarts c;
  double reference_peak_mb = 0;
  for (int i = 0; i < o.starts; ++i) {
    if (!reference.empty()) {
      const std::optional<nlohmann::json> r =
          RunTrack(o, reference, o.first_frame + i * o.start_stride, true, &reference_peak_mb);
      if (r) c.reference_tracking_median_ms.push_back(TrackingMedianMs(*r));
    }
    double peak_mb = 0;
    const std::optional<nlohmann::json> r =
        RunTrack(o, map, o.first_frame + i * o.start_stride, true, &peak_mb);
    if (!r) {
      ++c.failed;
      continue;
    }
    const nlohmann::json& startup = r->at("startup");
    if (startup.value("first_pose_frame", -1) >= 0) {
      c.first_pose_s.push_back(startup.at("first_pose_ms").get<double>() / 1e3);
    }
    c.map_load_s.push_back(startup.at("map_load_ms").get<double>() / 1e3);
    c.tracking_median_ms.push_back(TrackingMedianMs(*r));
    // An attempt's own time: a first direct attempt may wait for the index
    // that the load started building (its index_ms), which the index's
    // build time reports.
    for (const nlohmann::json& a : r->at("relocalization_attempts")) {
      c.relocalization_ms.push_back(a.at("ms").get<double>() - a.at("index_ms").get<double>());
      if (a.at("index_ms").get<double>() > 0) c.index_wait_ms.push_back(a.at("index_ms"));
    }
    c.index_ms.push_back(startup.at("relocalization_index_ms").get<double>());
    c.tracked += r->at("counts").at("tracked").get<int>();
    c.lost += r->at("counts").at("lost").get<int>();
    c.peak_mb.push_back(peak_mb);
  }
  if (!reference.empty()) {
    if (const auto r = RunTrack(o, reference, o.first_frame, false, &reference_peak_mb)) {
      c.reference_local_mapping_ms = LocalMappingMs(*r);
    }
  }
  double peak_mb = 0;
  if (const std::optional<nlohmann::json> r = RunTrack(o, map, o.first_frame, false, &peak_mb)) {
    c.local_mapping_ms = LocalMappingMs(*r);
    c.keyframes_created = r->at("map").at("keyframes_added").get<int>();
  } else {
    ++c.failed;
  }
  return c;
}

// The cold starts' figures; goals at 10k keyframes (`big`), tracking and
// local mapping against the base map's runs alternated with them
// (c.reference_*; none on the base map itself).
void AddColdStarts(const ColdStarts& c, const std::string& s, bool big, Report* report, Row* row) {
  const std::string n = std::to_string(c.map_load_s.size());
  const auto goal = [&](const std::string& text) { return big ? text : std::string("-"); };
  row->first_pose_s = c.first_pose_s.size() == c.map_load_s.size() ? Median(c.first_pose_s) : 0;
  row->tracking_median_ms = Median(c.tracking_median_ms);
  report->Add(s,
              {"cold starts: runs failed", static_cast<double>(c.failed), "", "0", c.failed == 0});
  report->Add(s, {"first pose after process start (median of " + n + " starts)", row->first_pose_s,
                  "s", goal("<= 2 s"), !big || (row->first_pose_s > 0 && row->first_pose_s <= 2)});
  report->Add(s, {"  of which the map's load (median)", Median(c.map_load_s), "s", "-", true});
  const std::string attempts =
      std::to_string(c.relocalization_ms.size()) + " attempts, without index waits";
  report->Add(s, {"relocalization attempt median (" + attempts + ")", Median(c.relocalization_ms),
                  "ms", "-", true});
  report->Add(s, {"relocalization attempt p95 (of these; the index built beside them)",
                  Percentile(c.relocalization_ms, 0.95), "ms", "-", true});
  report->Add(s, {"  map-point index build, beside tracking (median)", Median(c.index_ms), "ms",
                  "-", true});
  report->Add(s, {"  attempts that waited for it: " + std::to_string(c.index_wait_ms.size()) +
                      ", longest wait",
                  c.index_wait_ms.empty()
                      ? 0.0
                      : *std::max_element(c.index_wait_ms.begin(), c.index_wait_ms.end()),
                  "ms", "-", true});
  report->Add(s, {"tracking median per frame (median of the starts)", row->tracking_median_ms, "ms",
                  "-", true});
  if (!c.reference_tracking_median_ms.empty()) {
    const double base_ms = Median(c.reference_tracking_median_ms);
    report->Add(s,
                {"  the base map's, its starts alternated with these", base_ms, "ms", "-", true});
    const double ratio = row->tracking_median_ms / base_ms;
    report->Add(s,
                {"  against the base map's", ratio, "x", goal("<= 1.2 x"), !big || ratio <= 1.2});
  }
  report->Add(s, {"frames tracked", static_cast<double>(c.tracked), "", "-", true});
  report->Add(s, {"frames lost", static_cast<double>(c.lost), "", "-", true});
  report->Add(s, {"track peak memory (median)", Median(c.peak_mb), "MB", "-", true});
  row->local_mapping_ms = c.local_mapping_ms;
  report->Add(s, {"restore mapping: local mapping median per keyframe", c.local_mapping_ms, "ms",
                  "-", true});
  if (c.reference_local_mapping_ms > 0) {
    report->Add(
        s, {"  the base map's, run just before", c.reference_local_mapping_ms, "ms", "-", true});
    const double ratio = c.local_mapping_ms / c.reference_local_mapping_ms;
    report->Add(s,
                {"  against the base map's", ratio, "x", goal("<= 1.5 x"), !big || ratio <= 1.5});
  }
  report->Add(s, {"  keyframes it added", static_cast<double>(c.keyframes_created), "", "-", true});
}

// Relocalization attempts on `map` in process, every 10th of 500 frames
// from the first cold start's (relocalization_sweep.h); goal at 10k
// keyframes (`big`).
void AddRelocalizationSweep(const Options& o, const fs::path& map, const std::string& s, bool big,
                            Report* report, Row* row) {
  rrslam::bench::RelocalizationSweepOptions r;
  r.paths = {map, o.vocab, o.settings, o.sequence};
  r.first_frame = o.first_frame;
  const rrslam::bench::RelocalizationSweep sweep = rrslam::bench::SweepRelocalization(r);
  const std::string n = std::to_string(sweep.attempt_ms.size());
  const std::string frames = "every " + std::to_string(r.stride) + "th of frames " +
                             std::to_string(r.first_frame) + "-" +
                             std::to_string(r.first_frame + r.frames - 1);
  row->relocalization_p95_ms = Percentile(sweep.attempt_ms, 0.95);
  report->Add(s, {"relocalization attempt median (in process, " + n + " attempts: " + frames + ")",
                  Median(sweep.attempt_ms), "ms", "-", true});
  report->Add(s, {"relocalization attempt p95 (in process)", row->relocalization_p95_ms, "ms",
                  big ? "<= 30 ms" : "-", !big || row->relocalization_p95_ms <= 30});
  report->Add(s, {"  of which the bag-of-words stage: median", Median(sweep.bow_stage_ms), "ms",
                  "-", true});
  report->Add(s, {"    p95", Percentile(sweep.bow_stage_ms, 0.95), "ms", "-", true});
  report->Add(s, {"  attempts that gave a pose (of " + n + ")",
                  static_cast<double>(sweep.relocalized), "", "-", true});
  report->Add(s, {"    by the direct stage", static_cast<double>(sweep.by_direct), "", "-", true});
}

// Loop closing's `step` while tracking on `map` (goal at 3k keyframes and
// more, `big`).
void AddLoopStep(const Options& o, rrslam::bench::LoopStep step, const fs::path& map,
                 const std::string& s, bool big, Report* report, Row* row) {
  using rrslam::bench::LoopStep;
  rrslam::bench::LoopStepWhileTrackingOptions g;
  g.map = map;
  g.vocab = o.vocab;
  g.settings = o.settings;
  g.sequence = o.sequence;
  g.first_frame = o.first_frame;
  g.step = step;
  const rrslam::bench::LoopStepWhileTracking r = rrslam::bench::MeasureLoopStepWhileTracking(g);
  const bool ba = step == LoopStep::kGlobalBa;
  const std::string t = ba ? "global BA while tracking: " : "essential graph while tracking: ";
  const auto goal = [&](const std::string& text) { return big ? text : std::string("-"); };
  const std::string steps = std::to_string(r.iterations) +
                            " steps; one thread, beside tracking at 30 Hz (localization only)";
  if (ba) {
    report->Note(s, "global BA of " + std::to_string(r.keyframes) + " keyframes, " +
                        std::to_string(r.points) + " points, " + std::to_string(r.observations) +
                        " observations, " + steps);
  } else {
    report->Note(s, "essential graph of " + std::to_string(r.vertices) + " keyframes, " +
                        std::to_string(r.edges) + " edges, after a loop made up over " +
                        std::to_string(r.loop_ids) + " keyframe ids (" +
                        rrslam::Format("%.2f m, ", g.correction_m) +
                        rrslam::Format("%.1f deg", g.correction_deg) + "), " + steps);
  }
  const double before = Percentile(r.before_ms, 0.95), during = Percentile(r.during_ms, 0.95);
  (ba ? row->global_ba_s : row->essential_graph_s) = r.total_ms / 1e3;
  (ba ? row->ba_tracking_p95_before_ms : row->eg_tracking_p95_before_ms) = before;
  (ba ? row->ba_tracking_p95_during_ms : row->eg_tracking_p95_during_ms) = during;
  report->Add(s, {t + "time (collect, solve, apply)", r.total_ms / 1e3, "s", "-", true});
  report->Add(s, {"  collect under the map's lock", r.collect_ms, "ms", "-", true});
  report->Add(s, {"  solve without it", r.solve_ms, "ms", "-", true});
  report->Add(s, {"  apply under the map's lock", r.apply_ms, "ms", "-", true});
  report->Add(s, {t + "tracking p95 before (" + std::to_string(r.before_ms.size()) + " frames)",
                  before, "ms", "-", true});
  report->Add(s, {t + "tracking p95 during (" + std::to_string(r.during_ms.size()) + " frames)",
                  during, "ms", "-", true});
  report->Add(s, {"  during against before", during / before, "x", goal("<= 1.5 x"),
                  !big || (before > 0 && during / before <= 1.5)});
  report->Add(
      s, {t + "tracking max during",
          r.during_ms.empty() ? 0.0 : *std::max_element(r.during_ms.begin(), r.during_ms.end()),
          "ms", "-", true});
  report->Add(s, {t + "frames lost before / during",
                  static_cast<double>(r.lost_before + r.lost_during), "", "-", true});
}

Row MeasureSize(const Options& o, const rrslam::MapData& base, const rrslam::Vocabulary& vocab,
                int size, Report* report) {
  rrslam::ComposeOptions compose;
  compose.flipped_bits = o.flipped_bits;
  compose.copies = static_cast<int>((size + base.keyframes.size() - 1) / base.keyframes.size());
  const int levels_up = base.bow_levels_up;
  const auto rebag = [&](rrslam::KeyFrameRecord* kf) {
    rrslam::BowVector bow;
    rrslam::FeatureVector features;
    vocab.Transform(kf->descriptors, &bow, &features, levels_up);
    kf->bow.assign(bow.entries.begin(), bow.entries.end());
    kf->feature_vector.assign(features.entries.begin(), features.entries.end());
  };
  rrslam::MapData map;
  const double compose_s = SecondsOf([&] { map = rrslam::ComposeMap(base, compose, rebag); });
  const size_t keyframes = map.keyframes.size();
  const std::string s = std::to_string(keyframes) + " keyframes (" +
                        std::to_string(compose.copies) + " copies, " +
                        std::to_string(map.map_points.size()) + " map points)";
  const fs::path path = o.work / ("scale-" + std::to_string(size) + ".rrm");
  const double save_s = SecondsOf([&] { rrslam::WriteMapFile(path, map); });
  map = {};
  const double bytes = static_cast<double>(fs::file_size(path));
  std::vector<double> loads;
  for (int r = 0; r < 3; ++r) {
    loads.push_back(SecondsOf([&] { rrslam::ReadMapFile(path); }));
  }
  // Three whole processes: on a virtual machine the first touches of fresh
  // memory, most of a big load, vary by 2x from run to run.
  std::vector<double> verify_s;
  double peak_mb = 0;
  bool verified = true;
  for (int r = 0; r < 3; ++r) {
    const ChildRun run =
        RunChild({o.mapstore.string(), "--quiet", "verify", path.string()}, o.work / "verify.txt");
    verified = verified && run.exit_code == 0;
    verify_s.push_back(run.wall_s);
    peak_mb = std::max(peak_mb, run.max_rss_mb);
  }
  const double verify_median = Median(verify_s);
  const std::string spread =
      rrslam::Format("%.2f", *std::min_element(verify_s.begin(), verify_s.end())) + "-" +
      rrslam::Format("%.2f", *std::max_element(verify_s.begin(), verify_s.end())) + " s";
  const bool big = keyframes >= 10000;
  const auto goal = [&](const std::string& text) { return big ? text : std::string("-"); };
  report->Note(s, "composed in " + rrslam::Format("%.1f", compose_s) + " s");
  report->Add(s, {"file size", bytes / 1e6, "MB", "-", true});
  report->Add(s, {"bytes per keyframe", bytes / keyframes / 1e3, "kB", "<= 125 kB",
                  bytes / keyframes <= 125e3});
  report->Add(
      s, {"save (encode, write, fsync, rename)", save_s, "s", goal("<= 2 s"), !big || save_s <= 2});
  report->Add(s, {"load alone, in process (median of 3)", Median(loads), "s", "-", true});
  report->Add(s, {"verify, whole process (= load with every check; median of 3, " + spread + ")",
                  verify_median, "s", goal("<= 1 s"), verified && (!big || verify_median <= 1)});
  report->Add(s, {"  as the whole-process load", verify_median, "s", goal("<= 1.5 s"),
                  verified && (!big || verify_median <= 1.5)});
  const double ratio = peak_mb * 1e6 / bytes;
  report->Add(s, {"load peak memory / file size (largest of 3)", ratio, "x", goal("<= 2 x"),
                  !big || ratio <= 2});
  report->Add(s, {"load peak memory", peak_mb, "MB", "-", true});
  Row row{
      static_cast<double>(keyframes), save_s, Median(loads), verify_median, bytes / 1e6, peak_mb};
  if (!o.track.empty()) {
    AddColdStarts(RunColdStarts(o, path, o.map), s, big, report, &row);
    AddRelocalizationSweep(o, path, s, big, report, &row);
    AddLoopStep(o, rrslam::bench::LoopStep::kEssentialGraph, path, s, keyframes >= 3000, report,
                &row);
    if (static_cast<int>(keyframes) <= o.global_ba_max_keyframes) {
      AddLoopStep(o, rrslam::bench::LoopStep::kGlobalBa, path, s, keyframes >= 3000, report, &row);
    }
  }
  if (!o.keep) fs::remove(path);
  return row;
}

// The counts of `run_json` named by `keys`, each a figure of section `s`.
void AddRunCounts(const nlohmann::json& run_json, std::initializer_list<const char*> keys,
                  const std::string& s, Report* report) {
  const nlohmann::json& counts = run_json.at("counts");
  for (const char* key : keys) report->Add(s, {key, counts.at(key).get<double>(), "", "-", true});
}

// ATE RMSE of `out`'s CameraTrajectory.txt against `sequence`'s ground
// truth (rrslam-eval ate's defaults), cm.
double AteRmseCm(const fs::path& sequence, const fs::path& out) {
  return 100 * rrslam::ComputeAte(rrslam::ReadTumTrajectory(sequence / "groundtruth.txt"),
                                  rrslam::ReadTumTrajectory(out / "CameraTrajectory.txt"))
                   .error.rmse;
}

// The keyframes left at the end of the run in `out` (its
// KeyFrameTrajectory.txt) by the pass whose frame made them, `sequence`'s
// frames split into `passes` passes equal in time. Passes after the first
// may add at most 10% of the first's (issue 35).
void AddKeyframesByPass(const fs::path& sequence, const fs::path& out, int passes,
                        const std::string& s, Report* report) {
  const auto frames = rrslam::ReadTimestampList(sequence / "rgb.txt");
  const double start = frames.front().first, pass = (frames.back().first - start) / passes;
  std::vector<int> per_pass(passes, 0);
  for (const rrslam::StampedPose& kf : rrslam::ReadTumTrajectory(out / "KeyFrameTrajectory.txt")) {
    ++per_pass[std::min(passes - 1, static_cast<int>((kf.timestamp - start) / pass))];
  }
  for (int i = 0; i < passes; ++i) {
    report->Add(s, {"keyframes left from pass " + std::to_string(i + 1),
                    static_cast<double>(per_pass[i]), "", "-", true});
  }
  const int later = std::accumulate(per_pass.begin() + 1, per_pass.end(), 0);
  const double added = 100.0 * later / std::max(1, per_pass[0]);
  report->Add(s, {"later passes add, of the first's keyframes", added, "%", "<= 10 %",
                  per_pass[0] > 0 && added <= 10});
}

// One revisit case: `sequence` (its settings.yaml, or `settings`) passes
// over the same ground `passes` times, equal in time, mapped in one batch
// run of rrslam-track with --vocab and `args`; the keyframes left at the end
// by the pass whose frame made them. Passes after the first may add at most
// 10% of the first's (issue 35).
void MeasureRevisit(const Options& o, const std::string& s, const fs::path& sequence,
                    const fs::path& settings, int passes, const std::vector<std::string>& args,
                    Report* report) {
  const fs::path out = o.work / "revisit";
  std::vector<std::string> command = {
      o.track.string(),  "--quiet", "--sequence",     sequence.string(), "--settings",
      settings.string(), "--vocab", o.vocab.string(), "--out",           out.string()};
  command.insert(command.end(), args.begin(), args.end());
  const ChildRun run = RunChild(command, o.work / "revisit.txt");
  report->Add(s, {"run failed", run.exit_code == 0 ? 0.0 : 1.0, "", "0", run.exit_code == 0});
  if (run.exit_code != 0) return;
  std::ifstream in(out / "run.json");
  AddRunCounts(nlohmann::json::parse(in),
               {"tracked", "lost", "keyframes_created", "keyframes_culled", "loop_closures"}, s,
               report);
  AddKeyframesByPass(sequence, out, passes, s, report);
  report->Add(s, {"ATE RMSE", AteRmseCm(sequence, out), "cm", "-", true});
}

// Revisits (--synth): three laps of rrslam-synth's standard room loop; with
// --replay, a real sequence whose frames come twice (the same images: the
// second pass needs no keyframe). Each with the defaults, without the
// revisit culling (ORB-SLAM2's keyframes) and with --new-view-fraction 0.15
// (keyframes withheld on revisits) instead.
void MeasureRevisits(const Options& o, Report* report) {
  constexpr int kLaps = 3, kFramesPerLap = 570;  // 19 s at 30 Hz: one turn around per lap.
  const fs::path room = o.work / "revisit-loop-3-laps";
  if (!fs::exists(room / "rgb.txt")) {
    RunChild({o.synth.string(), "--quiet", "--out", room.string(), "--trajectory", "loop",
              "--frames", std::to_string(kLaps * kFramesPerLap + 1)},
             o.work / "synth.txt");
  }
  const std::vector<std::pair<std::string, std::vector<std::string>>> variants = {
      {"the defaults (revisit keyframes culled after the last frame)", {}},
      {"--no-cull-revisits (ORB-SLAM2's keyframes)", {"--no-cull-revisits"}},
      {"--new-view-fraction 0.15 --no-cull-revisits",
       {"--new-view-fraction", "0.15", "--no-cull-revisits"}}};
  for (const auto& [name, args] : variants) {
    MeasureRevisit(o, "revisits: the standard room, 3 laps of its loop (rrslam-synth), " + name,
                   room, room / "settings.yaml", kLaps, args, report);
    if (!o.replay.empty()) {
      MeasureRevisit(o, "revisits: " + o.replay.filename().string() + ", its frames twice, " + name,
                     o.replay, o.settings, 2, args, report);
    }
  }
}

// The building (--synth, --building-frames > 0): rrslam-synth's building
// and its tour (rendered once into --work), mapped in one batch run of
// rrslam-track with --vocab and --save-map: the map that a long sequence of
// new ground makes, with loops to close (issue 35, deliverable 1a). Over
// whole tours, the second and later revisit the first's rooms: the
// keyframes each tour leaves (AddKeyframesByPass).
void MeasureBuilding(const Options& o, Report* report) {
  // One tour's frames as rrslam-synth renders it (its default frame rate).
  const double fps = rrslam::SynthOptions{}.fps;
  const int tour_frames =
      static_cast<int>(std::lround(rrslam::synth::BuildingTour::Get().duration() * fps));
  const std::string frames = std::to_string(o.building_frames);
  const std::string s = "building: rrslam-synth --scene building --trajectory tour, " + frames +
                        " frames (one tour: " + std::to_string(tour_frames) + ")";
  const fs::path sequence = o.work / ("building-" + frames);
  if (!fs::exists(sequence / "rgb.txt")) {
    RunChild({o.synth.string(), "--quiet", "--out", sequence.string(), "--scene", "building",
              "--trajectory", "tour", "--frames", frames},
             o.work / "synth.txt");
  }
  const fs::path out = o.work / "building-run", map = o.work / "building.rrm";
  const ChildRun run =
      RunChild({o.track.string(), "--quiet", "--sequence", sequence.string(), "--settings",
                (sequence / "settings.yaml").string(), "--vocab", o.vocab.string(), "--out",
                out.string(), "--save-map", map.string()},
               o.work / "building.txt");
  report->Add(s, {"run failed", run.exit_code == 0 ? 0.0 : 1.0, "", "0", run.exit_code == 0});
  if (run.exit_code != 0) return;
  std::ifstream in(out / "run.json");
  const nlohmann::json r = nlohmann::json::parse(in);
  const nlohmann::json& counts = r.at("counts");
  AddRunCounts(r,
               {"tracked", "lost", "keyframes", "keyframes_created", "keyframes_culled",
                "map_points", "loop_closures"},
               s, report);
  const int tours = o.building_frames / tour_frames;
  if (tours >= 2 && o.building_frames % tour_frames == 0) {
    AddKeyframesByPass(sequence, out, tours, s, report);
  }
  const double minutes = o.building_frames / fps / 60.0;
  report->Add(s, {"keyframes per minute of camera time",
                  counts.at("keyframes").get<double>() / minutes, "", "-", true});
  report->Add(s, {"ATE RMSE", AteRmseCm(sequence, out), "cm", "-", true});
  const nlohmann::json& timings = r.at("timings");
  report->Add(s, {"tracking median", timings.at("tracking").at("median_ms").get<double>(), "ms",
                  "-", true});
  report->Add(s, {"  p95", timings.at("tracking").at("p95_ms").get<double>(), "ms", "-", true});
  report->Add(s, {"local mapping median per keyframe",
                  timings.at("local_mapping").at("median_ms").get<double>(), "ms", "-", true});
  report->Add(s, {"whole run (wall)", run.wall_s, "s", "-", true});
  report->Add(s, {"peak memory", run.max_rss_mb, "MB", "-", true});
  const double bytes = static_cast<double>(fs::file_size(map));
  report->Add(s, {"map file", bytes / 1e6, "MB", "-", true});
  report->Add(s, {"  bytes per keyframe", bytes / counts.at("keyframes").get<double>() / 1e3, "kB",
                  "<= 125 kB", bytes / counts.at("keyframes").get<double>() <= 125e3});
  if (!o.keep) fs::remove(map);
}

std::vector<int> ParseSizes(const std::string& text) {
  std::vector<int> sizes;
  std::stringstream in(text);
  for (std::string item; std::getline(in, item, ',');) sizes.push_back(std::stoi(item));
  return sizes;
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  std::string sizes = "1000,3000,10000";
  CLI::App app("bench_scale: map files at 1k, 3k and 10k keyframes, composed from a real map");
  app.add_option("--map", o.map)->required();
  app.add_option("--vocab", o.vocab)->required();
  app.add_option("--mapstore", o.mapstore)->required();
  app.add_option("--work", o.work)->required();
  app.add_option("--sizes", sizes);
  app.add_option("--machine", o.machine)->required();
  app.add_option("--out", o.out)->required();
  app.add_flag("--keep", o.keep, "Keep the composed maps in --work");
  app.add_option("--flipped-bits", o.flipped_bits, "Descriptor bits flipped in copies 1...");
  app.add_option("--track", o.track, "rrslam-track, for cold starts on each map");
  app.add_option("--sequence", o.sequence, "The cold starts' sequence (the base map's)");
  app.add_option("--settings", o.settings, "Its settings");
  app.add_option("--starts", o.starts, "Cold starts per map");
  app.add_option("--first-frame", o.first_frame, "Frame of the first cold start");
  app.add_option("--start-stride", o.start_stride, "Frames between cold starts");
  app.add_option("--frames", o.frames, "Frames tracked per cold start");
  app.add_option("--mapping-frames", o.mapping_frames,
                 "Frames of each restore-mapping run (local mapping per keyframe)");
  app.add_option("--synth", o.synth, "rrslam-synth, for the revisits (needs --track)");
  app.add_option("--replay", o.replay,
                 "A sequence of --settings whose frames come twice, for the revisits");
  app.add_option("--building-frames", o.building_frames,
                 "Frames of the building's tour mapped (with --synth; 0: none)");
  app.add_option("--global-ba-max-keyframes", o.global_ba_max_keyframes,
                 "Global BA while tracking on maps of at most this many keyframes (needs --track)");
  CLI11_PARSE(app, argc, argv);
  o.sizes = ParseSizes(sizes);
  fs::create_directories(o.work);
  const rrslam::MapData base = rrslam::ReadMapFile(o.map);
  const rrslam::Vocabulary vocab = rrslam::Vocabulary::Load(o.vocab);
  Report report;
  std::vector<Row> rows;
  Row base_row;
  if (!o.track.empty()) {
    const std::string s = "base map (" + std::to_string(base.keyframes.size()) + " keyframes)";
    AddColdStarts(RunColdStarts(o, o.map), s, false, &report, &base_row);
    AddRelocalizationSweep(o, o.map, s, false, &report, &base_row);
    AddLoopStep(o, rrslam::bench::LoopStep::kEssentialGraph, o.map, s, false, &report, &base_row);
    AddLoopStep(o, rrslam::bench::LoopStep::kGlobalBa, o.map, s, false, &report, &base_row);
  }
  for (const int size : o.sizes) {
    rows.push_back(MeasureSize(o, base, vocab, size, &report));
  }
  if (!o.synth.empty() && !o.track.empty()) {
    MeasureRevisits(o, &report);
    if (o.building_frames > 0) MeasureBuilding(o, &report);
  }
  WritePlots(o.out, rows, !o.track.empty());
  rrslam::bench::WriteGoalResults(o.out,
                                  "Issue 35: map files at scale, composed from " + o.map.string() +
                                      " (" + std::to_string(base.keyframes.size()) + " keyframes)",
                                  "make bench-scale BENCH_SCALE_MAP=" + o.map.string(), o.machine,
                                  report);
  return 0;
}
