// bench_render: `rrslam-render map` and `html` on a 200-keyframe,
// 20,000-point map against the goals of issue 14 (map pictures <= 1 s, HTML
// <= 5 MB). The map is generated (a room 8 x 6 x 3 m, keyframes on a loop
// looking at the walls, every point observed by at most 4 keyframes that
// see it) so the figure does not depend on a sequence.
//
// Usage: bench_render --bin DIR --runs DIR [--repeats N] --machine TEXT --out PREFIX
#include <CLI/CLI.hpp>
#include <chrono>
#include <cmath>
#include <random>

#include "bench/common/bench_report.h"
#include "common/atomic_file.h"
#include "stages/mapstore/map_file.h"
#include "stages/render/map_picture.h"
#include "stages/render/map_scene.h"
#include "stages/render/render_test_util.h"

namespace fs = std::filesystem;
using rrslam::bench::Figure;
using rrslam::bench::Quote;
using rrslam::bench::Report;
using rrslam::bench::Run;

namespace {

double Median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0 : v[v.size() / 2];
}

double SecondsOf(const std::function<void()>& f) {
  const auto start = std::chrono::steady_clock::now();
  f();
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

// A room of 8 x 3 x 6 m (y down, first camera at the origin), 20,000 points
// on its four walls between 1 m below and above the cameras; 200 keyframes
// on an ellipse looking outwards, so every point is seen.
rrslam::MapData BenchMap() {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(0, 1);
  std::vector<Eigen::Vector3d> points;
  while (points.size() < 20000) {
    const int face = static_cast<int>(u(rng) * 4);
    const double a = u(rng), height = -1 + 2 * u(rng);
    Eigen::Vector3d p;
    if (face == 0) p = {-4, height, -3 + 6 * a};
    if (face == 1) p = {4, height, -3 + 6 * a};
    if (face == 2) p = {-4 + 8 * a, height, -3};
    if (face == 3) p = {-4 + 8 * a, height, 3};
    points.push_back(p);
  }
  std::vector<rrslam::Rigid3d> poses;
  for (int i = 0; i < 200; ++i) {
    const double t = 2 * M_PI * i / 200.0;
    const Eigen::Vector3d centre(1.5 * std::sin(t), 0, 1.0 * (1 - std::cos(t)) - 1.0);
    // Looking outwards, turning with the path (about -y, the up axis).
    const Eigen::Quaterniond q(Eigen::AngleAxisd(t, Eigen::Vector3d::UnitY()));
    poses.emplace_back(q, centre);
  }
  return rrslam::testing::MakeKnownMap(poses, points, rrslam::testing::RenderTestCamera(), 4);
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app("Measures rrslam-render map and html on a 200-keyframe, 20k-point map.");
  fs::path bin, runs;
  int repeats = 5;
  std::string machine, out_prefix;
  app.add_option("--bin", bin, "Folder of the rrslam-* executables")->required();
  app.add_option("--runs", runs, "Folder for the outputs")->required();
  app.add_option("--repeats", repeats, "Runs of each command")->capture_default_str();
  app.add_option("--machine", machine, "Machine description line");
  app.add_option("--out", out_prefix, "Result files prefix (writes .txt and .json)")->required();
  CLI11_PARSE(app, argc, argv);
  fs::create_directories(runs);

  const rrslam::MapData map = BenchMap();
  const fs::path map_path = runs / "bench-200kf.rrm";
  rrslam::WriteMapFile(map_path, map);
  Report report;
  const std::string s = "map of " + std::to_string(map.keyframes.size()) + " keyframes, " +
                        std::to_string(map.map_points.size()) + " points";
  report.Note(s, "map file " + std::to_string(fs::file_size(map_path)) + " bytes");

  // Whole commands, process start included.
  const std::string render = (bin / "rrslam-render").string() + " --quiet ";
  const auto time_command = [&](const std::string& command) {
    std::vector<double> seconds;
    for (int r = 0; r < repeats; ++r) {
      int status = 0;
      seconds.push_back(SecondsOf([&] { status = Run(command); }));
      if (status != 0) {
        std::cerr << "bench_render: failed: " << command << "\n";
        std::exit(1);
      }
    }
    return Median(seconds);
  };
  const double startup = time_command(render + "--version > /dev/null");
  report.Add(s, {"rrslam-render --version (process start)", startup * 1000, "ms", "-", true});
  const double one_view = time_command(render + "map --map " + Quote(map_path) + " --out " +
                                       Quote(runs / "pictures") + " --view top");
  report.Add(s, {"render map, top view (whole command)", one_view * 1000, "ms", "<= 1000",
                 one_view <= 1.0});
  const double four_views =
      time_command(render + "map --map " + Quote(map_path) + " --out " + Quote(runs / "pictures"));
  report.Add(s, {"render map, 4 views (whole command)", four_views * 1000, "ms", "<= 1000",
                 four_views <= 1.0});

  // In process: reading the map, and each view.
  rrslam::MapScene scene;
  const double read = SecondsOf([&] { scene = rrslam::LoadMapScene(map_path); });
  report.Add(s, {"read map file and build the scene", read * 1000, "ms", "-", true});
  for (const auto kind : {rrslam::MapViewKind::kTop, rrslam::MapViewKind::kPerspective}) {
    std::vector<double> seconds;
    for (int r = 0; r < repeats; ++r) {
      seconds.push_back(
          SecondsOf([&] { rrslam::RenderMapPicture(scene, kind, rrslam::MapPictureOptions{}); }));
    }
    report.Add(s, {"draw " + rrslam::ToString(kind) + " view (in process)", Median(seconds) * 1000,
                   "ms", "-", true});
  }

  // HTML viewer size and time.
  const fs::path html = runs / "view.html";
  const double html_seconds =
      time_command(render + "html --map " + Quote(map_path) + " --out " + Quote(html));
  const double html_mb = static_cast<double>(fs::file_size(html)) / 1e6;
  report.Add(s, {"html file size", html_mb, "MB", "<= 5", html_mb <= 5.0});
  report.Add(s, {"render html (whole command)", html_seconds * 1000, "ms", "-", true});

  std::ostringstream text;
  text << "# bench_render (make bench-render)\n# machine: " << machine << "\n";
  for (int i = 0; i < argc; ++i) text << (i ? " " : "# command: ") << argv[i];
  text << "\n" << report.Text();
  nlohmann::ordered_json j;
  j["machine"] = machine;
  j["figures"] = report.Json();
  rrslam::WriteFileAtomically(out_prefix + ".txt", text.str());
  rrslam::WriteFileAtomically(out_prefix + ".json", j.dump(2) + "\n");
  std::cout << text.str();
  return report.AllPass() ? 0 : 1;
}
