// rrslam-render as a user runs it: each command on a small map with known
// geometry and a sequence whose images have known colours.
#include "stages/render/render_tool.h"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <sstream>

#include "common/atomic_file.h"
#include "common/errors.h"
#include "common/image_io.h"
#include "common/testing.h"
#include "common/trajectory.h"
#include "stages/mapstore/map_file.h"
#include "stages/mapstore/map_join.h"
#include "stages/render/image_file.h"
#include "stages/render/ply.h"
#include "stages/render/render_test_util.h"

namespace rrslam {
namespace {

using testing::Quote;
using testing::RunCommand;
using testing::RunTool;

class RenderTool : public ::testing::Test {
 protected:
  void SetUp() override {
    // Two keyframes 0.5 m apart looking along +z at a wall of points.
    const std::vector<Rigid3d> poses = {
        Rigid3d::Identity(), Rigid3d(Eigen::Quaterniond::Identity(), Eigen::Vector3d(0.5, 0, 0))};
    for (int i = 0; i < 30; ++i) {
      for (int j = 0; j < 10; ++j) points_.emplace_back(-1.0 + 0.1 * i, -0.5 + 0.1 * j, 3.0);
    }
    points_.emplace_back(-3.0, 0, 3.0);  // Seen by keyframe 0 only (left edge).
    map_ = testing::MakeKnownMap(poses, points_);
    WriteMapFile(dir_ / "m.rrm", map_);
    // A sequence: keyframe 0's image is red, keyframe 1's blue.
    const std::filesystem::path seq = dir_ / "seq";
    std::filesystem::create_directories(seq / "rgb");
    std::filesystem::create_directories(seq / "depth");
    std::string rgb_list, depth_list;
    for (int i = 0; i < 3; ++i) {  // One more frame than keyframes.
      const cv::Mat rgb(480, 640, CV_8UC3,
                        i == 0   ? cv::Scalar(0, 0, 255)
                        : i == 1 ? cv::Scalar(255, 0, 0)
                                 : cv::Scalar(0, 255, 0));
      const cv::Mat depth(480, 640, CV_16UC1, cv::Scalar(15000));
      const std::string name = fmt::format("{:.6f}.png", 100.0 + i);
      WritePng(seq / "rgb" / name, rgb);
      WritePng(seq / "depth" / name, depth);
      rgb_list += fmt::format("{:.6f} rgb/{}\n", 100.0 + i, name);
      depth_list += fmt::format("{:.6f} depth/{}\n", 100.0 + i, name);
    }
    testing::WriteTextFile(seq / "rgb.txt", rgb_list);
    testing::WriteTextFile(seq / "depth.txt", depth_list);
  }

  std::string path(const std::string& name) const { return (dir_ / name).string(); }

  testing::TempDir dir_;
  std::vector<Eigen::Vector3d> points_;
  MapData map_;
};

TEST_F(RenderTool, MapWritesEveryViewWithProducerMetadata) {
  const auto result = RunTool("render", "map --map " + path("m.rrm") + " --out " + path("pics"));
  ASSERT_EQ(result.exit_code, 0) << result.output;
  for (const char* view : {"top", "side", "front", "perspective"}) {
    const std::filesystem::path png = dir_ / "pics" / (std::string("map_") + view + ".png");
    ASSERT_TRUE(std::filesystem::exists(png)) << png;
    const cv::Mat image = ReadImage(png);
    EXPECT_EQ(image.size(), cv::Size(1200, 900));
    std::string software, options;
    for (const auto& [key, value] : ReadPictureMetadata(png)) {
      if (key == "Software") software = value;
      if (key == "rrslam:options") options = value;
    }
    EXPECT_EQ(software.rfind("rrslam-render ", 0), 0u) << software;
    EXPECT_NE(options.find(std::string("\"view\":\"") + view + "\""), std::string::npos) << options;
  }
  // One view, from a viewpoint file in ORB-SLAM2's settings layout.
  testing::WriteTextFile(dir_ / "view.yaml",
                         "%YAML:1.0\nViewer.ViewpointX: 0\nViewer.ViewpointY: -2\n"
                         "Viewer.ViewpointZ: -3\nViewer.ViewpointF: 400\n");
  const auto one = RunTool("render", "map --map " + path("m.rrm") + " --out " + path("one") +
                                         " --view perspective --viewpoint " + path("view.yaml") +
                                         " --color observations");
  ASSERT_EQ(one.exit_code, 0) << one.output;
  EXPECT_TRUE(std::filesystem::exists(dir_ / "one" / "map_perspective.png"));
  EXPECT_FALSE(std::filesystem::exists(dir_ / "one" / "map_top.png"));
}

TEST_F(RenderTool, PlyHasTheMapsPointsAndImageColours) {
  for (const bool binary : {false, true}) {
    const std::string out = path(binary ? "b.ply" : "a.ply");
    const auto result =
        RunTool("render", "ply --map " + path("m.rrm") + " --out " + out + " --sequence " +
                              path("seq") + (binary ? "" : " --ascii"));
    ASSERT_EQ(result.exit_code, 0) << result.output;
    const PlyCloud cloud = ReadPly(out);
    ASSERT_EQ(cloud.positions.size(), map_.map_points.size());
    ASSERT_EQ(cloud.colors.size(), cloud.positions.size());
    ASSERT_EQ(cloud.normals.size(), cloud.positions.size());
    for (size_t i = 0; i < map_.map_points.size(); ++i) {
      const MapPointRecord& mp = map_.map_points[i];
      for (int k = 0; k < 3; ++k) EXPECT_FLOAT_EQ(cloud.positions[i][k], float(mp.position[k]));
      EXPECT_EQ(cloud.observations[i], static_cast<int>(mp.observations.size()));
      // Seen in the red image only: red; in the red and the blue one: their mean.
      const std::array<uint8_t, 3> expected = mp.observations.size() == 1
                                                  ? std::array<uint8_t, 3>{255, 0, 0}
                                                  : std::array<uint8_t, 3>{128, 0, 128};
      EXPECT_EQ(cloud.colors[i], expected) << i;
      // Normals face the cameras: minus the mean viewing direction.
      for (int k = 0; k < 3; ++k) EXPECT_NEAR(cloud.normals[i][k], -mp.normal[k], 1e-6);
      EXPECT_LT(cloud.normals[i].z(), -0.8f);
    }
  }
  // Without a sequence: grey. Binary by default; the header names the frame
  // and calls the observations a scalar field (CloudCompare keeps it).
  ASSERT_EQ(RunTool("render", "ply --map " + path("m.rrm") + " --out " + path("g.ply")).exit_code,
            0);
  const PlyCloud grey = ReadPly(path("g.ply"));
  EXPECT_EQ(grey.colors.front(), (std::array<uint8_t, 3>{128, 128, 128}));
  const std::string header = ReadFileToString(path("g.ply")).substr(0, 600);
  EXPECT_NE(header.find("format binary_little_endian 1.0\n"), std::string::npos) << header;
  EXPECT_NE(header.find("property int scalar_observations\n"), std::string::npos) << header;
  EXPECT_NE(std::find(grey.comments.begin(), grey.comments.end(), kMapFrameComment),
            grey.comments.end());
}

// The PLY as CloudCompare, a program users hold, reads it: every point, its
// colour and normal, and the observations as a scalar field (a property not
// named scalar_* it drops). Skipped where CloudCompare is not installed.
TEST_F(RenderTool, CloudCompareKeepsEveryPropertyOfThePly) {
  if (RunCommand("command -v CloudCompare > /dev/null").exit_code != 0) {
    GTEST_SKIP() << "CloudCompare is not installed (scripts/install-deps.sh all installs it)";
  }
  const std::string ply = path("cc.ply");
  ASSERT_EQ(RunTool("render",
                    "ply --map " + path("m.rrm") + " --out " + ply + " --sequence " + path("seq"))
                .exit_code,
            0);
  const auto cc = RunCommand("QT_QPA_PLATFORM=offscreen CloudCompare -SILENT -NO_TIMESTAMP -O " +
                             Quote(ply) + " -C_EXPORT_FMT ASC -ADD_HEADER -SAVE_CLOUDS");
  ASSERT_EQ(cc.exit_code, 0) << cc.output;
  std::istringstream asc(ReadFileToString(path("cc.asc")));
  std::string header, line;
  std::getline(asc, header);
  EXPECT_EQ(header, "//X Y Z R G B observations Nx Ny Nz");
  size_t rows = 0;
  while (std::getline(asc, line)) rows += !line.empty();
  EXPECT_EQ(rows, map_.map_points.size());
}

// The COLMAP model as COLMAP itself (Debian's colmap 3.8) reads it: text and
// binary, images = keyframes, points = map points, the same mean track
// length and reprojection error; converted by COLMAP to PLY, the map's
// points; converted to text, the poses written. Skipped where colmap is not
// installed.
TEST_F(RenderTool, ColmapReadsTheModelWithTheMapsCounts) {
  if (RunCommand("command -v colmap > /dev/null").exit_code != 0) {
    GTEST_SKIP() << "colmap is not installed (scripts/install-deps.sh all installs it)";
  }
  size_t observations = 0;
  for (const MapPointRecord& p : map_.map_points) observations += p.observations.size();
  const std::string track_length = fmt::format(
      "Mean track length: {:.6f}", double(observations) / double(map_.map_points.size()));
  for (const char* format : {"", " --binary"}) {
    const std::string out = path(std::string("colmap") + (*format ? "-bin" : "-txt"));
    ASSERT_EQ(RunTool("render", "colmap --map " + path("m.rrm") + " --sequence " + path("seq") +
                                    " --out " + out + format)
                  .exit_code,
              0);
    EXPECT_TRUE(std::filesystem::exists(out + "/images/100.000000.png"));
    const auto analyzer = RunCommand("colmap model_analyzer --path " + out + "/sparse/0");
    ASSERT_EQ(analyzer.exit_code, 0) << analyzer.output;
    EXPECT_NE(analyzer.output.find(fmt::format("Registered images: {}", map_.keyframes.size())),
              std::string::npos)
        << analyzer.output;
    EXPECT_NE(analyzer.output.find(fmt::format("Points: {}", map_.map_points.size())),
              std::string::npos)
        << analyzer.output;
    EXPECT_NE(analyzer.output.find(track_length), std::string::npos) << analyzer.output;
    EXPECT_NE(analyzer.output.find("Mean reprojection error: 0.0"), std::string::npos)
        << analyzer.output;
  }
  // COLMAP's own conversions: to PLY (the points), to text (the poses).
  const std::string bin = path("colmap-bin") + "/sparse/0";
  ASSERT_EQ(RunCommand("colmap model_converter --input_path " + bin + " --output_path " +
                       path("colmap.ply") + " --output_type PLY")
                .exit_code,
            0);
  const PlyCloud ply = ReadPly(path("colmap.ply"));
  ASSERT_EQ(ply.positions.size(), map_.map_points.size());
  for (const Eigen::Vector3f& y : ply.positions) {  // In COLMAP's order: the nearest.
    double nearest = 1e9;
    for (const MapPointRecord& p : map_.map_points) {
      const Eigen::Vector3d x(p.position[0], p.position[1], p.position[2]);
      nearest = std::min(nearest, (y.cast<double>() - x).norm());
    }
    EXPECT_LT(nearest, 1e-6);
  }
  std::filesystem::create_directories(dir_ / "colmap-back");
  ASSERT_EQ(RunCommand("colmap model_converter --input_path " + bin + " --output_path " +
                       path("colmap-back") + " --output_type TXT")
                .exit_code,
            0);
  const ColmapModel back = ReadColmapModel(dir_ / "colmap-back", false);
  ASSERT_EQ(back.images.size(), map_.keyframes.size());
  for (const ColmapImage& image : back.images) {  // Image k + 1 is keyframe k.
    ASSERT_GE(image.id, 1u);
    ASSERT_LE(image.id, map_.keyframes.size());
    const Rigid3d T = RigidOf(map_.keyframes[image.id - 1].T_cam_world);
    EXPECT_LT((image.T_cam_world.translation - T.translation).norm(), 1e-9);
    EXPECT_LT(image.T_cam_world.rotation.angularDistance(T.rotation), 1e-9);
  }
}

// --frame floor where the map has no floor (a wall in front of the
// cameras): the camera frame is kept and the PLY says so; align-floor exits
// 75 and leaves the map file as it was.
TEST_F(RenderTool, FloorFrameKeepsTheCameraFrameWhereNoFloorIsFound) {
  const std::string before = ReadFileToString(dir_ / "m.rrm");
  const auto align = RunTool("mapstore", "align-floor " + path("m.rrm"));
  EXPECT_EQ(align.exit_code, 75) << align.output;
  EXPECT_NE(align.output.find("no floor found"), std::string::npos) << align.output;
  EXPECT_EQ(ReadFileToString(dir_ / "m.rrm"), before);
  const auto ply = RunTool(
      "render", "ply --map " + path("m.rrm") + " --out " + path("floor.ply") + " --frame floor");
  ASSERT_EQ(ply.exit_code, 0) << ply.output;
  EXPECT_NE(ply.output.find("no floor found"), std::string::npos) << ply.output;
  const std::string header = ReadFileToString(dir_ / "floor.ply").substr(0, 600);
  EXPECT_NE(header.find(kMapFrameComment), std::string::npos) << header;
  EXPECT_EQ(RunTool("render",
                    "ply --map " + path("m.rrm") + " --out " + path("x.ply") + " --frame ceiling")
                .exit_code,
            64);
}

// The wall map has no floor: octomap keeps the camera frame (and says so),
// grid refuses with exit 75 (heights need a floor) and writes nothing.
TEST_F(RenderTool, OctomapKeepsTheCameraFrameAndGridNeedsAFloor) {
  const std::string inputs = " --map " + path("m.rrm") + " --sequence " + path("seq");
  const auto octomap = RunTool("render", "octomap" + inputs + " --out " + path("m.bt"));
  ASSERT_EQ(octomap.exit_code, 0) << octomap.output;
  EXPECT_NE(octomap.output.find("no floor found"), std::string::npos) << octomap.output;
  const std::string header = ReadFileToString(dir_ / "m.bt").substr(0, 800);
  EXPECT_EQ(header.rfind("# Octomap OcTree binary file\n", 0), 0u) << header;
  EXPECT_NE(header.find(kMapFrameComment), std::string::npos) << header;

  const auto grid = RunTool("render", "grid" + inputs + " --out " + path("grid.yaml"));
  EXPECT_EQ(grid.exit_code, 75) << grid.output;
  EXPECT_NE(grid.output.find("m.rrm: no floor found"), std::string::npos) << grid.output;
  for (const char* name : {"grid.yaml", "grid.pgm", "grid.png"}) {
    EXPECT_FALSE(std::filesystem::exists(dir_ / name)) << name;
  }
  EXPECT_EQ(RunTool("render", "grid" + inputs + " --out " + path("grid.yaml") +
                                  " --min-height 2 --max-height 1")
                .exit_code,
            64);
  EXPECT_EQ(RunTool("render", "octomap" + inputs + " --out " + path("nofolder/m.bt")).exit_code,
            73);
}

TEST_F(RenderTool, TrajectoryAgainstGroundTruth) {
  Trajectory gt, est;
  for (int i = 0; i < 200; ++i) {
    const double t = 100 + i / 30.0;
    gt.push_back({t, Rigid3d(Eigen::Quaterniond::Identity(),
                             Eigen::Vector3d(std::cos(i / 30.0), std::sin(i / 30.0), 0))});
    est.push_back(
        {t, Rigid3d(Eigen::Quaterniond::Identity(),
                    Eigen::Vector3d(std::cos(i / 30.0) + 2, std::sin(i / 30.0) + 0.01, 0))});
  }
  WriteTumTrajectory(dir_ / "gt.txt", gt);
  WriteTumTrajectory(dir_ / "est.txt", est);
  const auto result = RunTool("render", "trajectory --est " + path("est.txt") + " --gt " +
                                            path("gt.txt") + " --out " + path("traj"));
  ASSERT_EQ(result.exit_code, 0) << result.output;
  EXPECT_NE(result.output.find("est.txt: ATE RMSE 0.0000 m over 200 pairs"), std::string::npos)
      << result.output;
  for (const char* name : {"top", "side", "front", "error"}) {
    EXPECT_TRUE(
        std::filesystem::exists(dir_ / "traj" / (std::string("trajectory_") + name + ".png")));
  }
}

TEST_F(RenderTool, BadInputsGetOneLineAndTheDocumentedCode) {
  // Missing map: 66 (no input), nothing written.
  auto r = RunTool("render", "map --map " + path("none.rrm") + " --out " + path("x"));
  EXPECT_EQ(r.exit_code, 66) << r.output;
  EXPECT_NE(r.output.find("none.rrm"), std::string::npos);
  EXPECT_FALSE(std::filesystem::exists(dir_ / "x"));
  // A corrupt map: 65.
  testing::WriteTextFile(dir_ / "bad.rrm", "not a map");
  r = RunTool("render", "ply --map " + path("bad.rrm") + " --out " + path("p.ply"));
  EXPECT_EQ(r.exit_code, 65) << r.output;
  EXPECT_FALSE(std::filesystem::exists(dir_ / "p.ply"));
  // Output folder whose parent is missing: 73.
  r = RunTool("render", "map --map " + path("m.rrm") + " --out " + path("no/such/dir"));
  EXPECT_EQ(r.exit_code, 73) << r.output;
  // Unknown view or colour: 64.
  r = RunTool("render", "map --map " + path("m.rrm") + " --out " + path("y") + " --view bottom");
  EXPECT_EQ(r.exit_code, 64) << r.output;
  r = RunTool("render", "map --map " + path("m.rrm") + " --out " + path("y") + " --color mood");
  EXPECT_EQ(r.exit_code, 64) << r.output;
  // A viewpoint file without the viewer keys: 65, naming the key.
  testing::WriteTextFile(dir_ / "cam.yaml", "%YAML:1.0\nCamera.fx: 500\n");
  r = RunTool("render", "map --map " + path("m.rrm") + " --out " + path("y") +
                            " --view perspective --viewpoint " + path("cam.yaml"));
  EXPECT_EQ(r.exit_code, 65) << r.output;
  EXPECT_NE(r.output.find("missing Viewer.ViewpointX"), std::string::npos) << r.output;
  // A sequence without the keyframes' frames: 65, naming the keyframe.
  std::filesystem::create_directories(dir_ / "other" / "rgb");
  std::filesystem::create_directories(dir_ / "other" / "depth");
  WritePng(dir_ / "other" / "rgb" / "1.png", cv::Mat(480, 640, CV_8UC3, cv::Scalar(0)));
  WritePng(dir_ / "other" / "depth" / "1.png", cv::Mat(480, 640, CV_16UC1, cv::Scalar(0)));
  testing::WriteTextFile(dir_ / "other" / "rgb.txt", "5.0 rgb/1.png\n");
  testing::WriteTextFile(dir_ / "other" / "depth.txt", "5.0 depth/1.png\n");
  r = RunTool("render", "ply --map " + path("m.rrm") + " --out " + path("p.ply") + " --sequence " +
                            path("other"));
  EXPECT_EQ(r.exit_code, 65) << r.output;
  EXPECT_NE(r.output.find("keyframe 1 (t = 100.000000) has no frame"), std::string::npos)
      << r.output;
  EXPECT_FALSE(std::filesystem::exists(dir_ / "p.ply"));
  // An output over an input: 64, the input untouched.
  const auto before = std::filesystem::file_size(dir_ / "m.rrm");
  r = RunTool("render", "ply --map " + path("m.rrm") + " --out " + path("m.rrm"));
  EXPECT_EQ(r.exit_code, 64) << r.output;
  EXPECT_NE(r.output.find("is the --map input"), std::string::npos) << r.output;
  EXPECT_EQ(std::filesystem::file_size(dir_ / "m.rrm"), before);
  r = RunTool("render", "ply --map " + path("m.rrm") + " --sequence " + path("seq") + " --out " +
                            path("seq/points.ply"));
  EXPECT_EQ(r.exit_code, 64) << r.output;
  r = RunTool("render", "map --map " + path("m.rrm") + " --out " + dir_.path().string());
  EXPECT_EQ(r.exit_code, 64) << r.output;
  EXPECT_NE(r.output.find("contains the --map input"), std::string::npos) << r.output;
  // A trajectory that does not overlap the ground truth in time: 65.
  Trajectory a = {{1.0, Rigid3d::Identity()}, {2.0, Rigid3d::Identity()}};
  Trajectory b = {{50.0, Rigid3d::Identity()}, {51.0, Rigid3d::Identity()}};
  WriteTumTrajectory(dir_ / "a.txt", a);
  WriteTumTrajectory(dir_ / "b.txt", b);
  r = RunTool("render", "trajectory --est " + path("a.txt") + " --gt " + path("b.txt") + " --out " +
                            path("t"));
  EXPECT_EQ(r.exit_code, 65) << r.output;
  EXPECT_FALSE(std::filesystem::exists(dir_ / "t"));
}

}  // namespace
}  // namespace rrslam
