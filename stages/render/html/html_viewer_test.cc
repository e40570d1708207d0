#include "stages/render/html/html_viewer.h"

#include <gtest/gtest.h>

#include <CLI/CLI.hpp>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstring>
#include <iostream>
#include <nlohmann/json.hpp>
#include <numbers>
#include <opencv2/core.hpp>
#include <random>

#include "common/atomic_file.h"
#include "common/errors.h"
#include "common/image_io.h"
#include "common/testing.h"
#include "stages/mapstore/map_file.h"
#include "stages/mapstore/map_test_util.h"

namespace rrslam {
namespace {

using testing::TempDir;

// ---------------------------------------------------------------------------
// Helpers

std::vector<uint8_t> DecodeBase64(const std::string& text) {
  std::vector<uint8_t> out;
  uint32_t bits = 0;
  int count = 0;
  for (const char c : text) {
    int v;
    if (c >= 'A' && c <= 'Z')
      v = c - 'A';
    else if (c >= 'a' && c <= 'z')
      v = c - 'a' + 26;
    else if (c >= '0' && c <= '9')
      v = c - '0' + 52;
    else if (c == '+')
      v = 62;
    else if (c == '/')
      v = 63;
    else
      break;  // '=' padding.
    bits = (bits << 6) | static_cast<uint32_t>(v);
    count += 6;
    if (count >= 8) {
      count -= 8;
      out.push_back(static_cast<uint8_t>((bits >> count) & 0xff));
    }
  }
  return out;
}

template <typename T>
std::vector<T> DecodeArray(const nlohmann::json& text) {
  const std::vector<uint8_t> bytes = DecodeBase64(text.get<std::string>());
  EXPECT_EQ(bytes.size() % sizeof(T), 0u);
  std::vector<T> values(bytes.size() / sizeof(T));
  std::memcpy(values.data(), bytes.data(), values.size() * sizeof(T));
  return values;
}

// The page's data object (<script type="application/json" id="rrslam-data">).
nlohmann::json PageData(const std::string& html) {
  const std::string open = "<script type=\"application/json\" id=\"rrslam-data\">";
  const size_t begin = html.find(open);
  if (begin == std::string::npos) return nullptr;
  const size_t end = html.find("</script>", begin);
  if (end == std::string::npos) return nullptr;
  return nlohmann::json::parse(html.substr(begin + open.size(), end - begin - open.size()));
}

size_t Count(const std::string& text, const std::string& what) {
  size_t n = 0;
  for (size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
  return n;
}

std::string Lower(std::string text) {
  std::transform(text.begin(), text.end(), text.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return text;
}

// Every address in the page that a browser could fetch: "http://..." and
// "https://..." (but the XML namespace names three.js passes to
// document.createElementNS, which are identifiers and never fetched),
// protocol-relative CDN addresses, and elements that load a resource.
std::vector<std::string> ExternalReferences(const std::string& html) {
  const std::string lower = Lower(html);
  std::vector<std::string> found;
  for (const std::string scheme : {"http://", "https://"}) {
    for (size_t at = lower.find(scheme); at != std::string::npos; at = lower.find(scheme, at + 1)) {
      const size_t end = lower.find_first_of("\"'` )<>", at);
      const std::string url = html.substr(at, end == std::string::npos ? 80 : end - at);
      if (url == "http://www.w3.org/1999/xhtml" || url == "http://www.w3.org/2000/svg") continue;
      found.push_back(url);
    }
  }
  for (const std::string pattern :
       {"//cdn", "<script src", "<link", "<img", "<iframe", "@import"}) {
    if (lower.find(pattern) != std::string::npos) found.push_back(pattern);
  }
  return found;
}

Rigid3d PoseOfRecord(const MapPose& p) {
  return Rigid3d(Eigen::Quaterniond(p.qw, p.qx, p.qy, p.qz), Eigen::Vector3d(p.tx, p.ty, p.tz))
      .Inverse();
}

MapPose RecordOfPose(const Rigid3d& T_world_cam) {
  const Rigid3d T = T_world_cam.Inverse();
  const Eigen::Quaterniond q = T.rotation.normalized();
  return {q.w(), q.x(), q.y(), q.z(), T.translation.x(), T.translation.y(), T.translation.z()};
}

// A map whose picture the test can predict. 10 keyframes 0.3 m apart along
// the map's x axis (yawed by at most 3 degrees), all looking along +z with
// image rows along +y (as a level hand-held camera whose first frame is the
// map's origin), so the view frame is x right, y up = map -y. 380 points on
// a low slab in front of them (map y = +1, a metre below the cameras) spread
// over x in [-2, 2], and a cluster of 120 points a metre above the cameras
// (map y = -1) on the right (x = +1.8): the highest points, so red.
constexpr int kClusterPoints = 120;
const Eigen::Vector3d kClusterCentre(1.8, -1.0, 4.0);

MapData PredictableMap() {
  testing::TestMapOptions o;
  o.keyframes = 10;
  o.keypoints = 200;
  o.map_points = 500;
  o.min_observations = 1;
  o.max_observations = 2;
  MapData map = testing::MakeTestMap(7, o);
  for (size_t i = 0; i < map.keyframes.size(); ++i) {
    const double yaw = 0.05 * (static_cast<double>(i % 3) - 1.0);  // Radians, about the map's y.
    const Eigen::Vector3d centre(-1.5 + 0.3 * i, 0.05 * std::sin(i), 0.1 * (i % 2));
    map.keyframes[i].T_cam_world = RecordOfPose(
        Rigid3d(Eigen::Quaterniond(Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitY())), centre));
  }
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  for (size_t j = 0; j < map.map_points.size(); ++j) {
    double* p = map.map_points[j].position;
    if (static_cast<int>(j) < kClusterPoints) {
      p[0] = kClusterCentre.x() + 0.2 * unit(rng);
      p[1] = kClusterCentre.y() + 0.03 * unit(rng);
      p[2] = kClusterCentre.z() + 0.2 * unit(rng);
    } else {
      p[0] = 2.0 * unit(rng);
      p[1] = 1.0 + 0.1 * unit(rng);
      p[2] = 4.0 + 1.5 * unit(rng);
    }
  }
  return map;
}

// The keyframe trajectory of `map` seen from another world frame (as a
// motion-capture ground truth would be): T_other_map * T_map_cam.
Trajectory TrajectoryInOtherFrame(const MapData& map) {
  const Rigid3d T_other_map(
      Eigen::Quaterniond(Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized())),
      Eigen::Vector3d(4, -2, 1));
  Trajectory trajectory;
  for (const KeyFrameRecord& kf : map.keyframes) {
    trajectory.push_back({kf.timestamp, T_other_map * PoseOfRecord(kf.T_cam_world)});
  }
  return trajectory;
}

template <typename Options>
void ExpectCheckFails(const Options& o, const std::string& field) {
  std::string why;
  EXPECT_FALSE(o.Check(&why)) << field;
  EXPECT_NE(why.find(field), std::string::npos) << why;
}

template <typename ErrorType, typename F>
void ExpectThrowNaming(F&& f, const std::string& text) {
  try {
    f();
    ADD_FAILURE() << "no exception; expected one naming " << text;
  } catch (const ErrorType& e) {
    EXPECT_NE(std::string(e.what()).find(text), std::string::npos) << e.what();
  } catch (const std::exception& e) {
    ADD_FAILURE() << "wrong exception type: " << e.what();
  }
}

// ---------------------------------------------------------------------------
// Options

TEST(HtmlOptions, Checks) {
  std::string why;
  HtmlOptions o;
  ExpectCheckFails(o, "map");
  o.map = "m.rrm";
  ExpectCheckFails(o, "out");
  o.out = "view.html";
  EXPECT_TRUE(o.Check(&why)) << why;
  HtmlOptions bad = o;
  bad.gt = {"gt.txt", ""};
  ExpectCheckFails(bad, "gt:");
  bad = o;
  bad.est = {""};
  ExpectCheckFails(bad, "est:");
  bad = o;
  bad.out = "./m.rrm";
  ExpectCheckFails(bad, "out");
  bad = o;
  bad.est = {std::filesystem::current_path() / "view.html"};
  ExpectCheckFails(bad, "out");
  bad = o;
  bad.title = "two\nlines";
  ExpectCheckFails(bad, "title");

  const auto j = o.ToJson();
  EXPECT_EQ(j["map"], "m.rrm");
  EXPECT_EQ(j["out"], "view.html");
  EXPECT_TRUE(j["gt"].is_array());
}

TEST(HtmlOptions, Flags) {
  CLI::App app;
  CLI::App* html = app.add_subcommand("html");
  HtmlOptions o;
  BindHtmlOptions(html, &o);
  app.parse("html --map m.rrm --gt a.txt --gt b.txt --est c.txt --out v.html --title T", false);
  EXPECT_EQ(o.map, "m.rrm");
  EXPECT_EQ(o.gt, (std::vector<std::filesystem::path>{"a.txt", "b.txt"}));
  EXPECT_EQ(o.est, (std::vector<std::filesystem::path>{"c.txt"}));
  EXPECT_EQ(o.out, "v.html");
  EXPECT_EQ(o.title, "T");
  CLI::App app2;
  HtmlOptions o2;
  BindHtmlOptions(app2.add_subcommand("html"), &o2);
  EXPECT_THROW(app2.parse("html --out v.html", false), CLI::RequiredError);
}

// ---------------------------------------------------------------------------
// View frame

TEST(HtmlViewer, ViewFrameOfLevelCameras) {
  MapScene scene;
  scene.keyframes.resize(4);
  EXPECT_TRUE(ViewFromMap(scene).isApprox(Eigen::Vector3d(1, -1, -1).asDiagonal().toDenseMatrix()))
      << "no keyframes: the map frame's -y is up, +z forward";
  // Cameras sharing one orientation Q: the view's right, up and back are the
  // cameras' x, -y and -z.
  const Eigen::Quaterniond q(Eigen::AngleAxisd(1.2, Eigen::Vector3d(0.3, -1, 0.5).normalized()));
  for (SceneKeyFrame& kf : scene.keyframes) kf.T_world_cam.rotation = q;
  const Eigen::Matrix3d R = q.toRotationMatrix();
  Eigen::Matrix3d expected;
  expected << R.col(0).transpose(), -R.col(1).transpose(), -R.col(2).transpose();
  const Eigen::Matrix3d R_view_map = ViewFromMap(scene);
  EXPECT_TRUE(R_view_map.isApprox(expected, 1e-9)) << R_view_map << "\n\n" << expected;
  // One camera pitched 30 degrees down: its own frame (the cameras' mean up is
  // the only estimate of up), still a proper rotation.
  scene.keyframes.resize(1);
  scene.keyframes[0].T_world_cam.rotation =
      Eigen::Quaterniond(Eigen::AngleAxisd(-std::numbers::pi / 6, Eigen::Vector3d::UnitX()));
  const Eigen::Matrix3d pitched = ViewFromMap(scene);
  EXPECT_TRUE((pitched * pitched.transpose()).isIdentity(1e-9));
  EXPECT_NEAR(pitched.determinant(), 1.0, 1e-9);
  EXPECT_TRUE(pitched.row(1).transpose().isApprox(
      -scene.keyframes[0].T_world_cam.RotationMatrix().col(1), 1e-9));
}

TEST(HtmlViewer, ViewFrameFallsBackWhenCamerasDisagree) {
  // Random orientations (MakeTestMap): no common up; the map's own axes.
  MapScene scene;
  std::mt19937 rng(5);
  std::normal_distribution<double> normal;
  for (int i = 0; i < 200; ++i) {
    SceneKeyFrame kf;
    kf.T_world_cam.rotation =
        Eigen::Quaterniond(normal(rng), normal(rng), normal(rng), normal(rng)).normalized();
    scene.keyframes.push_back(kf);
  }
  const Eigen::Matrix3d R_view_map = ViewFromMap(scene);
  EXPECT_TRUE(R_view_map.isApprox(Eigen::Vector3d(1, -1, -1).asDiagonal().toDenseMatrix()))
      << R_view_map;
}

// ---------------------------------------------------------------------------
// The page

TEST(HtmlViewer, PageHoldsTheMapTrajectoriesAndMetadata) {
  const MapData map = PredictableMap();
  const MapScene scene = MakeMapScene(map, "maps/room.rrm");
  const Trajectory est = scene.KeyFrameTrajectory();
  const std::string html =
      BuildViewerHtml(scene, {{"run A", est}}, "a <b>room</b> & \"its\" </script> map",
                      "rrslam-render 9.9", nlohmann::ordered_json{{"k", 1}});

  EXPECT_EQ(html.rfind("<!DOCTYPE html>", 0), 0u);
  // The title is shown escaped and cannot end the script elements.
  EXPECT_NE(html.find("a &lt;b&gt;room&lt;/b&gt; &amp; &quot;its&quot; &lt;/script&gt; map"),
            std::string::npos);
  EXPECT_EQ(Count(Lower(html), "</script"), 2u) << "only the data and the viewer end a script";
  EXPECT_NE(html.find("map: maps/room.rrm"), std::string::npos);
  EXPECT_NE(html.find("made by rrslam-render 9.9"), std::string::npos);
  EXPECT_NE(html.find("500 map points · 10 keyframes"), std::string::npos);
  EXPECT_NE(html.find("Content-Security-Policy"), std::string::npos);
  EXPECT_NE(html.find(std::string(ViewerScript())), std::string::npos);
  EXPECT_GT(ViewerScript().size(), 100000u) << "three.js is in the bundle";
  EXPECT_EQ(ExternalReferences(html), std::vector<std::string>{});

  const nlohmann::json data = PageData(html);
  ASSERT_TRUE(data.is_object());
  EXPECT_EQ(data["format"], "rrslam.viewer");
  EXPECT_EQ(data["version"], 1);
  EXPECT_EQ(data["title"], "a <b>room</b> & \"its\" </script> map");
  EXPECT_EQ(data["producer"], "rrslam-render 9.9");
  EXPECT_EQ(data["options"]["k"], 1);
  EXPECT_EQ(data["counts"]["points"], 500);
  EXPECT_EQ(data["counts"]["keyframes"], 10);
  EXPECT_EQ(data["counts"]["loop_edges"], 1);
  EXPECT_EQ(data["camera"]["width"], 640);

  const std::vector<float> points = DecodeArray<float>(data["points"]);
  ASSERT_EQ(points.size(), 3 * scene.points.size());
  for (size_t i = 0; i < scene.points.size(); ++i) {
    for (int k = 0; k < 3; ++k) {
      EXPECT_FLOAT_EQ(points[3 * i + k], static_cast<float>(scene.points[i].position[k]));
    }
  }
  const std::vector<float> poses = DecodeArray<float>(data["keyframe_poses"]);
  ASSERT_EQ(poses.size(), 12 * scene.keyframes.size());
  for (size_t i = 0; i < scene.keyframes.size(); ++i) {
    const Eigen::Matrix<double, 3, 4> m = scene.keyframes[i].T_world_cam.ToMatrix3x4();
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 4; ++c) EXPECT_NEAR(poses[12 * i + 4 * r + c], m(r, c), 1e-6);
    }
  }
  const std::vector<uint32_t> loops = DecodeArray<uint32_t>(data["loop_edges"]);
  EXPECT_EQ(loops, (std::vector<uint32_t>{1, 9})) << "keyframe indices, each edge once";
  EXPECT_FALSE(data.contains("keyframe_loaded")) << "no loaded part";
  ASSERT_EQ(data["trajectories"].size(), 1u);
  EXPECT_EQ(data["trajectories"][0]["name"], "run A");
  EXPECT_EQ(data["trajectories"][0]["poses"], 10);
  const std::vector<float> track = DecodeArray<float>(data["trajectories"][0]["positions"]);
  ASSERT_EQ(track.size(), 30u);
  EXPECT_NEAR(track[3], est[1].T_world_cam.translation.x(), 1e-6);
  // Level cameras along +z: x right, y up = -y of the map.
  const std::vector<double> R = data["view_from_map"];
  ASSERT_EQ(R.size(), 9u);
  EXPECT_NEAR(R[0], 1, 0.01);
  EXPECT_NEAR(R[4], -1, 0.01);
  EXPECT_NEAR(R[8], -1, 0.01);
}

TEST(HtmlViewer, LoadedPartIsMarked) {
  MapData map = PredictableMap();
  map.metadata = R"({"loaded_map":{"next_keyframe_id":10,"next_map_point_id":100}})";
  const MapScene scene = MakeMapScene(map, "restored.rrm");
  const std::string html = BuildViewerHtml(scene, {}, "restored", "p");
  const nlohmann::json data = PageData(html);
  const std::vector<uint8_t> loaded = DecodeBase64(data["keyframe_loaded"].get<std::string>());
  ASSERT_EQ(loaded.size(), 10u);
  for (size_t i = 0; i < loaded.size(); ++i) {
    EXPECT_EQ(loaded[i], scene.keyframes[i].id < 10 ? 1 : 0) << i;
  }
  EXPECT_EQ(data["counts"]["loaded_keyframes"],
            std::count_if(scene.keyframes.begin(), scene.keyframes.end(),
                          [](const SceneKeyFrame& kf) { return kf.loaded; }));
  EXPECT_NE(html.find("500 map points (20 loaded) · 10 keyframes (3 loaded)"), std::string::npos);
}

// Size goal: a 20k-point map (with 300 keyframes and a 3000-pose ground
// truth) fits in 5 MB; three.js and the viewer are most of a small page.
TEST(HtmlViewer, PageSize) {
  const std::string empty = BuildViewerHtml(MapScene{}, {}, "empty", "p");
  MapScene scene;
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> unit(-3.0, 3.0);
  for (int i = 0; i < 20000; ++i) {
    ScenePoint p;
    p.id = i;
    p.position = Eigen::Vector3d(unit(rng), unit(rng), unit(rng));
    scene.points.push_back(p);
  }
  Trajectory gt;
  for (int i = 0; i < 3000; ++i) {
    StampedPose pose;
    pose.timestamp = 0.03 * i;
    pose.T_world_cam.translation = Eigen::Vector3d(std::cos(0.002 * i), 0, std::sin(0.002 * i));
    gt.push_back(pose);
    if (i % 10 == 0) {
      SceneKeyFrame kf;
      kf.id = i;
      kf.timestamp = pose.timestamp;
      kf.T_world_cam = pose.T_world_cam;
      scene.keyframes.push_back(kf);
    }
  }
  const std::string big = BuildViewerHtml(scene, {{"ground truth", gt}}, "20k", "p");
  std::cout << "[ size     ] empty page " << empty.size() << " bytes (viewer script "
            << ViewerScript().size() << "), 20000 points + 300 keyframes + 3000 poses "
            << big.size() << " bytes\n";
  RecordProperty("empty_page_bytes", static_cast<int>(empty.size()));
  RecordProperty("page_20k_points_bytes", static_cast<int>(big.size()));
  EXPECT_LE(big.size(), 5'000'000u);
  // The data are base64 of float32: 16 bytes of text per point.
  EXPECT_LE(big.size() - empty.size(), 20000 * 16 + 300 * (64 + 16) + 3000 * 16 + 4096);
}

// ---------------------------------------------------------------------------
// RunHtml

class HtmlRun : public ::testing::Test {
 protected:
  void SetUp() override {
    map_ = PredictableMap();
    WriteMapFile(dir_ / "room.rrm", map_);
    WriteTumTrajectory(dir_ / "gt.txt", TrajectoryInOtherFrame(map_));
    options_.map = dir_ / "room.rrm";
    options_.out = dir_ / "view.html";
  }
  TempDir dir_;
  MapData map_;
  HtmlOptions options_;
};

TEST_F(HtmlRun, WritesThePageWithAlignedGroundTruth) {
  options_.gt = {dir_ / "gt.txt"};
  options_.est = {dir_ / "gt.txt"};  // Any TUM file: drawn as it is.
  RunHtml(options_);
  const std::string html = ReadFileToString(options_.out);
  EXPECT_EQ(testing::TemporaryLeftovers(dir_), std::vector<std::string>{});
  const nlohmann::json data = PageData(html);
  ASSERT_TRUE(data.is_object());
  EXPECT_EQ(data["title"], "room.rrm");
  EXPECT_EQ(data["map"], options_.map.string());
  EXPECT_EQ(data["producer"].get<std::string>().rfind("rrslam-render ", 0), 0u);
  EXPECT_EQ(data["options"]["gt"][0], (dir_ / "gt.txt").string());
  ASSERT_EQ(data["trajectories"].size(), 2u);
  EXPECT_NE(data["trajectories"][0]["name"].get<std::string>().find("ground truth"),
            std::string::npos);
  EXPECT_NE(data["trajectories"][0]["name"].get<std::string>().find("gt.txt"), std::string::npos);
  // The ground truth, aligned, lies on the keyframe centres; the estimate is
  // drawn unchanged (so here it is somewhere else).
  const std::vector<float> gt = DecodeArray<float>(data["trajectories"][0]["positions"]);
  const std::vector<float> est = DecodeArray<float>(data["trajectories"][1]["positions"]);
  ASSERT_EQ(gt.size(), 3 * map_.keyframes.size());
  const Trajectory other = TrajectoryInOtherFrame(map_);
  for (size_t i = 0; i < map_.keyframes.size(); ++i) {
    const Eigen::Vector3d centre = PoseOfRecord(map_.keyframes[i].T_cam_world).translation;
    for (int k = 0; k < 3; ++k) {
      EXPECT_NEAR(gt[3 * i + k], centre[k], 1e-4) << i;
      EXPECT_NEAR(est[3 * i + k], other[i].T_world_cam.translation[k], 1e-5) << i;
    }
  }
  options_.title = "Kitchen";
  RunHtml(options_);
  EXPECT_EQ(PageData(ReadFileToString(options_.out))["title"], "Kitchen");
}

TEST_F(HtmlRun, Errors) {
  HtmlOptions o = options_;
  o.out.clear();
  ExpectThrowNaming<UsageError>([&] { RunHtml(o); }, "out");

  o = options_;
  o.map = dir_ / "missing.rrm";
  ExpectThrowNaming<NoInputError>([&] { RunHtml(o); }, "missing.rrm");

  WriteFileAtomically(dir_ / "junk.rrm", "not a map at all, just text");
  o.map = dir_ / "junk.rrm";
  ExpectThrowNaming<DataError>([&] { RunHtml(o); }, "junk.rrm");

  o = options_;
  o.gt = {dir_ / "no-gt.txt"};
  ExpectThrowNaming<NoInputError>([&] { RunHtml(o); }, "no-gt.txt");

  testing::WriteTextFile(dir_ / "bad-gt.txt", "1000.0 1 2 3\n");
  o.gt = {dir_ / "bad-gt.txt"};
  ExpectThrowNaming<DataError>([&] { RunHtml(o); }, "bad-gt.txt");

  // Stamps an hour away from every keyframe: nothing to align with.
  Trajectory late = TrajectoryInOtherFrame(map_);
  for (StampedPose& pose : late) pose.timestamp += 3600;
  WriteTumTrajectory(dir_ / "late-gt.txt", late);
  o.gt = {dir_ / "late-gt.txt"};
  ExpectThrowNaming<DataError>([&] { RunHtml(o); }, "late-gt.txt");

  o = options_;
  o.out = dir_ / "no-such-folder" / "view.html";
  ExpectThrowNaming<CantCreateError>([&] { RunHtml(o); }, "view.html");
  EXPECT_FALSE(std::filesystem::exists(options_.out)) << "nothing written on errors";
}

// ---------------------------------------------------------------------------
// In a browser: headless Chromium renders the page with WebGL (SwiftShader,
// no GPU) and with every network request refused.

constexpr char kChromium[] = "/usr/bin/chromium";

struct BrowserView {
  int exit_code = -1;
  std::string dom;  // The document after its scripts ran (--dump-dom).
  std::string log;  // Chromium's stderr.
  cv::Mat picture;  // BGR screenshot, 800 x 600.
};

// Opens `page` (with URL fragment `fragment`) in headless Chromium offline:
// a proxy that refuses every connection and a resolver that finds no host,
// so the page renders only if it needs nothing from outside.
BrowserView OpenInChromium(const std::filesystem::path& page, const std::string& fragment,
                           const TempDir& dir) {
  const std::filesystem::path shot = dir / "screenshot.png";
  const std::string command =
      "{ timeout 60 " + std::string(kChromium) +
      " --headless=new --no-sandbox --disable-gpu --use-angle=swiftshader"
      " --enable-unsafe-swiftshader --no-first-run --no-default-browser-check"
      " --disable-background-networking --disable-component-update --disable-sync"
      " --disable-quic --proxy-server=127.0.0.1:9 --host-resolver-rules='MAP * ~NOTFOUND'"
      " --user-data-dir='" +
      (dir / "profile").string() +
      "' --window-size=800,600 --force-device-scale-factor=1 --hide-scrollbars"
      " --virtual-time-budget=2000 --screenshot='" +
      shot.string() + "' --dump-dom 'file://" + std::filesystem::absolute(page).string() +
      fragment + "' > '" + (dir / "dom.html").string() + "' 2> '" +
      (dir / "chromium.log").string() + "'; }";
  BrowserView view;
  view.exit_code = testing::RunCommand(command).exit_code;
  if (std::filesystem::exists(dir / "dom.html")) view.dom = ReadFileToString(dir / "dom.html");
  if (std::filesystem::exists(dir / "chromium.log")) {
    view.log = ReadFileToString(dir / "chromium.log");
  }
  if (std::filesystem::exists(shot)) view.picture = ReadImage(shot, ImageReadMode::kColor);
  return view;
}

TEST_F(HtmlRun, RendersOfflineInChromium) {
  ASSERT_TRUE(std::filesystem::exists(kChromium))
      << kChromium << " not found: the browser test needs Debian's chromium; run "
      << "scripts/install-deps.sh";
  options_.gt = {dir_ / "gt.txt"};
  RunHtml(options_);
  const std::string html = ReadFileToString(options_.out);
  ASSERT_EQ(ExternalReferences(html), std::vector<std::string>{});

  // Without the panel (#hide-panel), so every coloured pixel is the scene.
  const BrowserView view = OpenInChromium(options_.out, "#hide-panel", dir_);
  ASSERT_EQ(view.exit_code, 0) << view.log;
  EXPECT_NE(view.dom.find("data-rrslam-viewer=\"ready\""), std::string::npos)
      << "the viewer did not draw its first frame:\n"
      << view.dom.substr(0, 2000) << "\n"
      << view.log;
  EXPECT_NE(view.dom.find("id=\"rrslam-canvas\""), std::string::npos);
  EXPECT_NE(view.dom.find("map points (500)"), std::string::npos) << "the legend";
  ASSERT_FALSE(view.picture.empty()) << view.log;
  ASSERT_EQ(view.picture.cols, 800);
  ASSERT_EQ(view.picture.rows, 600);

  // Background #14171c; "red" is the top of the height colours (hue 0-12
  // degrees: R ~ 238, G <= 82, B ~ 44); nothing else drawn is red.
  int drawn = 0, red = 0;
  double red_x = 0, red_y = 0;
  for (int y = 0; y < view.picture.rows; ++y) {
    for (int x = 0; x < view.picture.cols; ++x) {
      const cv::Vec3b bgr = view.picture.at<cv::Vec3b>(y, x);
      const int b = bgr[0], g = bgr[1], r = bgr[2];
      if (std::abs(r - 0x14) + std::abs(g - 0x17) + std::abs(b - 0x1c) > 60) ++drawn;
      if (r > 170 && g < 110 && b < 110) {
        ++red;
        red_x += x;
        red_y += y;
      }
    }
  }
  EXPECT_GT(drawn, 3000) << "the picture is (nearly) blank";
  ASSERT_GT(red, 150) << "the high cluster (red) is not drawn";
  red_x /= red;
  red_y /= red;
  // The documented initial view: map +x (view x) is screen right, high
  // points (view y) are in the upper half.
  EXPECT_GT(red_x, 0.6 * 800) << "the cluster at map x = +1.8 m must be on the right";
  EXPECT_LT(red_y, 0.5 * 600) << "the cluster a metre above the cameras must be in the upper half";
}

}  // namespace
}  // namespace rrslam
