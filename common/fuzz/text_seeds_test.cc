// The seed corpora of the text-reader fuzz targets in common/fuzz/, made here
// by code (no real data): fuzz/corpus/settings, tum_lists and trajectory.
//
// Each test writes its seeds and checks that every one is accepted by its
// reader (a seed that is rejected teaches the fuzzer little), except the
// settings seeds made to reach one of ParseYamlText's refusals (issue 36),
// which check that they are refused by that check. With
// RRSLAM_WRITE_FUZZ_SEEDS=<dir> the seeds go to <dir>/corpus/<name> (to
// regenerate the committed seeds, see `make fuzz-seeds`:
//   RRSLAM_WRITE_FUZZ_SEEDS=common/fuzz build/tests/common_text_seeds
// ), otherwise to a temporary folder.
#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "common/dataset.h"
#include "common/errors.h"
#include "common/geometry.h"
#include "common/settings.h"
#include "common/testing.h"
#include "common/trajectory.h"

namespace rrslam {
namespace {

// Writes `seeds` (file name -> content) to <RRSLAM_WRITE_FUZZ_SEEDS or
// `temp`>/corpus/`name`, and returns that folder.
std::filesystem::path WriteSeeds(const std::string& name,
                                 const std::map<std::string, std::string>& seeds,
                                 const testing::TempDir& temp) {
  const std::filesystem::path out = testing::FuzzSeedFolder(temp) / "corpus" / name;
  std::filesystem::create_directories(out);
  for (const auto& [name, content] : seeds) testing::WriteTextFile(out / name, content);
  return out;
}

TEST(TextSeeds, Settings) {
  const std::string intrinsics =
      "%YAML:1.0\nCamera.fx: 500\nCamera.fy: 505.5\nCamera.cx: 320\nCamera.cy: 240\n";
  Settings full;
  full.fx = 517.25;
  full.fy = 516.5;
  full.cx = 318.625;
  full.cy = 255.375;
  full.distortion = {0.25, -0.875, 0.001, -0.002, 1.125};
  full.width = 640;
  full.height = 480;
  full.depth_noise = {DepthNoise::Model::kQuadratic, 1.425e-3, 0.25};
  full.orb.n_features = 1500;
  // The layout of ORB-SLAM2's example settings (comments, "#----" rules,
  // viewer and other keys the reader ignores), with invented values.
  const std::string orbslam2 =
      "%YAML:1.0\n\n"
      "#--------------------------------------------------------------------\n"
      "# Camera Parameters. Adjust them!\n"
      "#--------------------------------------------------------------------\n\n"
      "# Camera calibration and distortion parameters (OpenCV)\n"
      "Camera.fx: 520.5\nCamera.fy: 519.25\nCamera.cx: 325.125\nCamera.cy: 249.75\n\n"
      "Camera.k1: 0.125\nCamera.k2: -0.5\nCamera.p1: 0.0\nCamera.p2: 0.0\n\n"
      "Camera.width: 640\nCamera.height: 480\n\n"
      "# Camera frames per second\nCamera.fps: 30.0\n\n"
      "# IR projector baseline times fx (aprox.)\nCamera.bf: 40.0\n\n"
      "# Color order of the images (0: BGR, 1: RGB. It is ignored if images are grayscale)\n"
      "Camera.RGB: 1\n\n"
      "# Close/Far threshold. Baseline times.\nThDepth: 40.0\n\n"
      "# Deptmap values factor\nDepthMapFactor: 5000.0\n\n"
      "ORBextractor.nFeatures: 1000\nORBextractor.scaleFactor: 1.2\n"
      "ORBextractor.nLevels: 8\nORBextractor.iniThFAST: 20\nORBextractor.minThFAST: 7\n\n"
      "Viewer.KeyFrameSize: 0.05\nViewer.KeyFrameLineWidth: 1\nViewer.GraphLineWidth: 0.9\n"
      "Viewer.PointSize: 2\nViewer.CameraSize: 0.08\nViewer.CameraLineWidth: 3\n"
      "Viewer.ViewpointX: 0\nViewer.ViewpointY: -0.7\nViewer.ViewpointZ: -1.8\n"
      "Viewer.ViewpointF: 500\n";
  // Issue 36's checks in ParseYamlText (common/yaml_text.h), reached from
  // both sides: a key "Nested" holding collections to a depth of 60 (passes)
  // and 70 (over kMaxYamlNesting = 64; the top-level map counts as one), in
  // flow style ('[' and "{a: " in turn) and block style (one more indented
  // map per line); a key given twice; an integer OpenCV would wrap to 20.
  const auto flow = [&](int levels) {
    std::string open, close;
    for (int i = 0; i < levels - 1; ++i) {
      open += i % 2 == 0 ? "[" : "{a: ";
      close = (i % 2 == 0 ? "]" : "}") + close;
    }
    return intrinsics + "Nested: " + open + "1" + close + "\n";
  };
  const auto block = [&](int levels) {
    std::string text = intrinsics + "Nested:\n";
    for (int i = 1; i < levels - 1; ++i) text += std::string(i, ' ') + "a:\n";
    return text + std::string(levels - 1, ' ') + "a: 1\n";
  };
  testing::TempDir temp;
  const auto dir =
      WriteSeeds("settings",
                 {{"minimal.yaml", intrinsics},
                  {"full.yaml", FormatSettings(full)},
                  {"orbslam2.yaml", orbslam2},
                  {"viewpoint.yaml", intrinsics + "Viewer.ViewpointX: 0.5\n"
                                                  "Viewer.ViewpointY: -0.7\n"
                                                  "Viewer.ViewpointZ: -1.8\n"
                                                  "Viewer.ViewpointF: 420\n"},
                  {"nested_60_flow.yaml", flow(60)},
                  {"nested_60_block.yaml", block(60)},
                  {"nested_70_flow.yaml", flow(70)},
                  {"nested_70_block.yaml", block(70)},
                  {"duplicate_key.yaml", intrinsics + "Camera.fx: 501\n"},
                  {"integer_4294967316.yaml", intrinsics + "Camera.width: 4294967316\n"}},
                 temp);
  for (const char* name : {"minimal.yaml", "full.yaml", "orbslam2.yaml", "viewpoint.yaml",
                           "nested_60_flow.yaml", "nested_60_block.yaml"}) {
    EXPECT_NO_THROW(ReadSettings(dir / name)) << name;
  }
  EXPECT_NO_THROW(ReadViewpoint(dir / "orbslam2.yaml"));
  EXPECT_NO_THROW(ReadViewpoint(dir / "viewpoint.yaml"));
  const std::pair<const char*, std::string> refused[] = {
      {"nested_70_flow.yaml", "line 6: YAML nested deeper than 64 levels"},
      {"nested_70_block.yaml", "line 70: YAML nested deeper than 64 levels"},
      {"duplicate_key.yaml", "line 6: key 'Camera.fx' is given twice"},
      {"integer_4294967316.yaml", "line 6: integer 4294967316 does not fit in 32 bits"}};
  for (const auto& [name, message] : refused) {
    try {
      (void)ReadSettings(dir / name);
      ADD_FAILURE() << name << " accepted";
    } catch (const DataError& e) {
      EXPECT_EQ(std::string(e.what()), (dir / name).string() + ": " + message);
    }
  }
}

TEST(TextSeeds, TumLists) {
  std::string rgb = "# color images\n# file: 'invented.bag'\n# timestamp filename\n";
  std::string depth = "# depth maps\n# file: 'invented.bag'\n# timestamp filename\n";
  std::string associations;
  for (int i = 0; i < 6; ++i) {
    char rgb_stamp[32], depth_stamp[32];
    std::snprintf(rgb_stamp, sizeof(rgb_stamp), "%.6f", 1000.0 + i / 30.0);
    // Depth 4 ms later, and one frame without depth.
    std::snprintf(depth_stamp, sizeof(depth_stamp), "%.6f", 1000.004 + i / 30.0);
    rgb += std::string(rgb_stamp) + " rgb/" + rgb_stamp + ".png\n";
    if (i != 3) depth += std::string(depth_stamp) + " depth/" + depth_stamp + ".png\n";
    associations += std::string(rgb_stamp) + " rgb/" + rgb_stamp + ".png " + depth_stamp +
                    " depth/" + depth_stamp + ".png\n";
  }
  testing::TempDir temp;
  // The fuzz target reads a form feed as the boundary between the rgb and
  // the depth list.
  const auto dir = WriteSeeds("tum_lists",
                              {{"rgb.txt", rgb},
                               {"rgb_and_depth.txt", rgb + "\f" + depth},
                               {"associations.txt", associations},
                               {"separators.txt",
                                "# tabs, commas, CR LF\n1.5\trgb/a.png\r\n"
                                "2.25,rgb/b.png,extra\n\n3 rgb/c.png\n"}},
                              temp);
  EXPECT_EQ(ParseTimestampList(rgb, "rgb.txt").size(), 6u);
  EXPECT_EQ(ParseTimestampList(depth, "depth.txt").size(), 5u);
  EXPECT_EQ(ParseAssociations(associations, "seq", "associations.txt").size(), 6u);
  EXPECT_EQ(ReadTimestampList(dir / "separators.txt").size(), 3u);
  std::vector<double> a, b;
  for (const auto& [t, path] : ParseTimestampList(rgb, "rgb.txt")) a.push_back(t);
  for (const auto& [t, path] : ParseTimestampList(depth, "depth.txt")) b.push_back(t);
  EXPECT_EQ(AssociateTimestamps(a, b, 0.02).size(), 5u);
}

TEST(TextSeeds, Trajectory) {
  Trajectory t;
  for (int i = 0; i < 5; ++i) {
    StampedPose p;
    p.timestamp = 1000.0 + i / 30.0;
    p.T_world_cam = Rigid3d(ExpSO3({0.01 * i, -0.02 * i, 0.3}), {0.1 * i, 1.5, -0.25 * i});
    t.push_back(p);
  }
  testing::TempDir temp;
  const auto dir =
      WriteSeeds("trajectory",
                 {{"written.txt", FormatTumTrajectory(t)},
                  {"groundtruth.txt",
                   "# ground truth trajectory\n# file: 'invented.bag'\n"
                   "# timestamp tx ty tz qx qy qz qw\n"
                   "1000.0000 1.2500 0.6250 1.5000 0.5000 0.5000 -0.5000 -0.5000\n"
                   "1000.0100,1.2490,0.6260,1.4990,0.5010,0.4990,-0.5000,-0.5000\n"
                   "1000.0200\t1.2480\t0.6270\t1.4980\t0.5020\t0.4980\t-0.5000\t-0.5000\r\n"}},
                 temp);
  EXPECT_EQ(ReadTumTrajectory(dir / "written.txt").size(), 5u);
  EXPECT_EQ(ReadTumTrajectory(dir / "groundtruth.txt").size(), 3u);
}

}  // namespace
}  // namespace rrslam
