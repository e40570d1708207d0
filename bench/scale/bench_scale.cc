// bench_scale: how map files scale with keyframes (`make bench-scale`,
// issue 35), on maps composed from a real one (stages/mapstore/map_compose.h:
// copies of the map on a 20 m grid, descriptors perturbed by 24 bits, bags
// of words recomputed with the map's vocabulary).
//
//   bench_scale --map MAP --vocab VOC --mapstore BIN --work DIR
//               [--sizes 1000,3000,10000] --machine TEXT --out PREFIX
// For each size (keyframes, rounded up to whole copies): composes the map,
// writes it (save time: encode, write, fsync, rename, in process), its file
// size and bytes per keyframe, loads it in process (ReadMapFile: every
// checksum and relation; median of 3), and runs `BIN verify` as a child
// process (the whole process to a loaded, verified map: wall time and peak
// memory). Goals at 10k keyframes (issue 35): load <= 1.5 s whole process,
// peak memory <= 2x the file size, save <= 2 s, verify <= 1 s; file size
// per keyframe no larger than ~125 kB.
// Not yet measured here: relocalization and first pose, tracking and local
// mapping, global BA on the large maps (issue 35's other curves).
// Writes PREFIX.txt and PREFIX.json, and the curves as PREFIX-time.png and
// PREFIX-memory.png.
#include <CLI/CLI.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "bench/common/bench_report.h"
#include "common/chart.h"
#include "common/clock.h"
#include "common/image_io.h"
#include "stages/mapstore/map_compose.h"
#include "stages/mapstore/map_file.h"
#include "stages/vocab/vocabulary.h"

namespace {

namespace fs = std::filesystem;
using rrslam::bench::ChildRun;
using rrslam::bench::Median;
using rrslam::bench::Report;
using rrslam::bench::RunChild;

struct Options {
  fs::path map, vocab, mapstore, work;
  std::vector<int> sizes = {1000, 3000, 10000};
  std::string machine, out;
  bool keep = false;  // Keep the composed maps in `work` (else each is removed once measured).
};

// One size's figures, for the plots.
struct Row {
  double keyframes = 0;
  double save_s = 0, load_s = 0, verify_s = 0;  // Seconds.
  double file_mb = 0, peak_mb = 0;              // 10^6 bytes.
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

// bench/results/PREFIX-{time,memory}.png: the curves of every size.
void WritePlots(const std::string& out, const std::vector<Row>& rows) {
  Curve save{"save (s)", {40, 40, 200}, {}}, load{"load in process (s)", {200, 120, 40}, {}},
      verify{"verify, whole process (s)", {40, 150, 40}, {}};
  Curve file{"file (MB)", {200, 120, 40}, {}}, peak{"load peak memory (MB)", {40, 40, 200}, {}};
  for (const Row& r : rows) {
    save.points.emplace_back(r.keyframes, r.save_s);
    load.points.emplace_back(r.keyframes, r.load_s);
    verify.points.emplace_back(r.keyframes, r.verify_s);
    file.points.emplace_back(r.keyframes, r.file_mb);
    peak.points.emplace_back(r.keyframes, r.peak_mb);
  }
  rrslam::WritePng(out + "-time.png",
                   PlotCurves("map file times against keyframes", "seconds", {save, load, verify}));
  rrslam::WritePng(out + "-memory.png",
                   PlotCurves("map file and load memory against keyframes", "MB", {file, peak}));
}

double SecondsOf(const std::function<void()>& f) {
  const auto start = rrslam::SteadyClock::now();
  f();
  return rrslam::MillisecondsSince(start) / 1000.0;
}

Row MeasureSize(const Options& o, const rrslam::MapData& base, const rrslam::Vocabulary& vocab,
                int size, Report* report) {
  rrslam::ComposeOptions compose;
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
  const ChildRun verify =
      RunChild({o.mapstore.string(), "--quiet", "verify", path.string()}, o.work / "verify.txt");
  const bool big = keyframes >= 10000;
  const auto goal = [&](const std::string& text) { return big ? text : std::string("-"); };
  report->Note(s, "composed in " + rrslam::Format("%.1f", compose_s) + " s");
  report->Add(s, {"file size", bytes / 1e6, "MB", "-", true});
  report->Add(s, {"bytes per keyframe", bytes / keyframes / 1e3, "kB", "<= 125 kB",
                  bytes / keyframes <= 125e3});
  report->Add(
      s, {"save (encode, write, fsync, rename)", save_s, "s", goal("<= 2 s"), !big || save_s <= 2});
  report->Add(s, {"load alone, in process (median of 3)", Median(loads), "s", "-", true});
  report->Add(s, {"verify, whole process (= load with every check)", verify.wall_s, "s",
                  goal("<= 1 s"), verify.exit_code == 0 && (!big || verify.wall_s <= 1)});
  report->Add(s, {"  as the whole-process load", verify.wall_s, "s", goal("<= 1.5 s"),
                  verify.exit_code == 0 && (!big || verify.wall_s <= 1.5)});
  const double ratio = verify.max_rss_mb * 1e6 / bytes;
  report->Add(s, {"load peak memory / file size", ratio, "x", goal("<= 2 x"), !big || ratio <= 2});
  report->Add(s, {"load peak memory", verify.max_rss_mb, "MB", "-", true});
  if (!o.keep) fs::remove(path);
  return {static_cast<double>(keyframes),
          save_s,
          Median(loads),
          verify.wall_s,
          bytes / 1e6,
          verify.max_rss_mb};
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
  CLI11_PARSE(app, argc, argv);
  o.sizes = ParseSizes(sizes);
  fs::create_directories(o.work);
  const rrslam::MapData base = rrslam::ReadMapFile(o.map);
  const rrslam::Vocabulary vocab = rrslam::Vocabulary::Load(o.vocab);
  Report report;
  std::vector<Row> rows;
  for (const int size : o.sizes) rows.push_back(MeasureSize(o, base, vocab, size, &report));
  WritePlots(o.out, rows);
  rrslam::bench::WriteGoalResults(o.out,
                                  "Issue 35: map files at scale, composed from " + o.map.string() +
                                      " (" + std::to_string(base.keyframes.size()) + " keyframes)",
                                  "make bench-scale BENCH_SCALE_MAP=" + o.map.string(), o.machine,
                                  report);
  return 0;
}
