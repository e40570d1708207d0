// End to end, offline maps: rrslam-synth renders a short room loop and a
// vocabulary is trained on it; rrslam-track maps it and saves the map
// (--save-map); a second run loads it (--load-map) and localizes in it
// (--localization-only) from a later frame, in the map's frame; bad map
// inputs are refused with one line and their exit code.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>

#include "common/atomic_file.h"
#include "common/dataset.h"
#include "common/geometry.h"
#include "common/image_io.h"
#include "common/testing.h"
#include "common/text.h"
#include "common/trajectory.h"
#include "tests/room_pipeline.h"

namespace rrslam {
namespace {

namespace fs = std::filesystem;

using testing::Quote;
using testing::ReadJson;

constexpr int kFrames = 120;

class MapPipelineTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new testing::TempDir();
    testing::PrepareRoomSequence(
        dir_->path(), "--trajectory loop --frames " + std::to_string(kFrames) + " --seed 3");
    if (HasFatalFailure()) return;
    // The map of the whole loop.
    const auto r = Track(path("mapping"), "--save-map " + Quote(map()));
    ASSERT_EQ(r.exit_code, 0) << r.output;
  }
  static void TearDownTestSuite() {
    delete dir_;
    dir_ = nullptr;
  }
  static fs::path path(const std::string& name) { return dir_->path() / name; }
  static fs::path seq() { return path("room"); }
  static fs::path settings() { return seq() / "settings.yaml"; }
  static fs::path vocab() { return path("room.rrv"); }
  static fs::path map() { return path("room.rrm"); }

  static testing::CommandResult Track(const fs::path& out, const std::string& extra) {
    return testing::RunTool("track", "--quiet --sequence " + Quote(seq()) + " --settings " +
                                         Quote(settings()) + " --vocab " + Quote(vocab()) +
                                         " --out " + Quote(out) + " " + extra);
  }

  static testing::TempDir* dir_;
};
testing::TempDir* MapPipelineTest::dir_ = nullptr;

TEST_F(MapPipelineTest, SavedMapVerifiesAndMatchesTheRun) {
  const nlohmann::json run = ReadJson(path("mapping") / "run.json");
  const nlohmann::json& m = run.at("map");
  EXPECT_EQ(m.at("mode").get<std::string>(), "new map");
  EXPECT_EQ(m.at("saved").get<std::string>(), map().string());
  EXPECT_EQ(m.at("file_bytes").get<uint64_t>(), fs::file_size(map()));
  EXPECT_EQ(m.at("saved_identity").get<std::string>().size(), 16u);

  const auto verify = testing::RunTool("mapstore", "verify " + Quote(map()));
  EXPECT_EQ(verify.exit_code, 0) << verify.output;
  const auto info = testing::RunTool("mapstore", "info --json " + Quote(map()));
  ASSERT_EQ(info.exit_code, 0) << info.output;
  EXPECT_NE(info.output.find(std::to_string(run.at("counts").at("keyframes").get<int>())),
            std::string::npos);
}

// Start-up on the saved map from frame 30, localization only: the first
// frame relocalizes, every frame is tracked, nothing is added to the map,
// and the poses are those of the mapping run (the map's frame, no
// alignment) within a centimetre.
TEST_F(MapPipelineTest, LocalizationOnlyTracksEveryFrameInTheMapsFrame) {
  const fs::path out = path("localization");
  const auto r = Track(out, "--load-map " + Quote(map()) + " --localization-only --first-frame 30");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const nlohmann::json run = ReadJson(out / "run.json");
  EXPECT_EQ(run.at("counts").at("frames").get<int>(), kFrames - 30);
  EXPECT_EQ(run.at("counts").at("tracked").get<int>(), kFrames - 30);
  EXPECT_EQ(run.at("counts").at("resets").get<int>(), 0);
  const nlohmann::json& m = run.at("map");
  EXPECT_EQ(m.at("mode").get<std::string>(), "localization only");
  EXPECT_EQ(m.at("keyframes_added").get<int>(), 0);
  EXPECT_EQ(m.at("map_points_added").get<int>(), 0);
  EXPECT_EQ(m.at("keyframes_culled").get<int>(), 0);
  EXPECT_EQ(m.at("map_points_culled").get<int>(), 0);
  const nlohmann::json& startup = run.at("startup");
  EXPECT_EQ(startup.at("first_pose_frame").get<int>(), 30);
  EXPECT_GT(startup.at("map_load_ms").get<double>(), 0.0);
  EXPECT_GT(startup.at("first_pose_ms").get<double>(), startup.at("map_load_ms").get<double>());

  const Trajectory mapped = ReadTumTrajectory(path("mapping") / "CameraTrajectory.txt");
  const Trajectory localized = ReadTumTrajectory(out / "CameraTrajectory.txt");
  ASSERT_EQ(localized.size(), static_cast<size_t>(kFrames - 30));
  double worst = 0;
  for (size_t k = 0; k < localized.size(); ++k) {
    const StampedPose& a = mapped[30 + k];
    const StampedPose& b = localized[k];
    ASSERT_NEAR(a.timestamp, b.timestamp, 1e-6);
    worst = std::max(worst, (a.T_world_cam.translation - b.T_world_cam.translation).norm());
  }
  EXPECT_LT(worst, 0.01);
}

// Restore mapping on the same scene, in realtime mode (local mapping and
// loop closing in their threads on the loaded map): the loaded map is mapped
// on, the saved map keeps the loaded keyframes, and hardly a point is judged
// changed.
TEST_F(MapPipelineTest, RestoreMappingExtendsTheLoadedMap) {
  const fs::path out = path("restore"), updated = path("updated.rrm");
  const auto r = Track(out, "--load-map " + Quote(map()) + " --save-map " + Quote(updated) +
                                " --first-frame 60 --mode realtime");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const nlohmann::json run = ReadJson(out / "run.json");
  EXPECT_EQ(run.at("counts").at("tracked").get<int>(), kFrames - 60);
  const nlohmann::json& m = run.at("map");
  EXPECT_EQ(m.at("mode").get<std::string>(), "restore mapping");
  EXPECT_EQ(m.at("keyframes_loaded").get<int>(),
            ReadJson(path("mapping") / "run.json").at("counts").at("keyframes").get<int>());
  // Nothing changed: few loaded points are taken for changed ones.
  EXPECT_LE(m.at("changed_points_culled").get<double>(),
            0.02 * m.at("map_points_loaded").get<double>());
  EXPECT_EQ(testing::RunTool("mapstore", "verify " + Quote(updated)).exit_code, 0);
}

// Issue 31: the same frames mapped again, three times, each session on the
// last one's saved map (batch mode). The map has every view, so no session
// grows it: each keeps its points within 2% of those loaded (the earlier
// rule, a keyframe every second with 70 close keypoints untracked, added
// 3.5-3.8% a session here), the keyframes after session 3 are at most 1.1x
// those after session 1, and hardly a point is judged changed (at most 1%
// of those loaded).
TEST_F(MapPipelineTest, RepeatedSessionsDoNotGrowTheMap) {
  fs::path loaded = map();
  std::vector<int> keyframes;
  for (int session = 1; session <= 3; ++session) {
    const std::string name = "repeat" + std::to_string(session);
    const fs::path saved = path(name + ".rrm");
    const auto r = Track(path(name), "--load-map " + Quote(loaded) + " --save-map " + Quote(saved));
    ASSERT_EQ(r.exit_code, 0) << r.output;
    const nlohmann::json m = ReadJson(path(name) / "run.json").at("map");
    keyframes.push_back(m.at("keyframes_loaded").get<int>() + m.at("keyframes_added").get<int>() -
                        m.at("keyframes_culled").get<int>());
    const int loaded_points = m.at("map_points_loaded").get<int>();
    const int points =
        loaded_points + m.at("map_points_added").get<int>() - m.at("map_points_culled").get<int>();
    EXPECT_LE(points, 1.02 * loaded_points) << "session " << session;
    EXPECT_LE(m.at("changed_points_culled").get<double>(), 0.01 * loaded_points)
        << "session " << session;
    std::cerr << "session " << session << ": " << keyframes.back() << " keyframes, " << points
              << " points, " << m.at("changed_points_culled").get<int>() << " of " << loaded_points
              << " loaded points culled as changed\n";
    loaded = saved;
  }
  EXPECT_LE(keyframes.back(), 1.1 * keyframes.front());
}

// Points of a diff report (map_points.added / removed) inside `box`, a
// world-frame box of the synthetic room grown by `margin`, with the map's
// frame given by T_map_world.
int PointsIn(const nlohmann::json& points, const nlohmann::json& box, const Rigid3d& T_map_world,
             double margin) {
  Eigen::Vector3d lo, hi;
  for (int a = 0; a < 3; ++a) {
    lo[a] = box.at("bounds_min")[a].get<double>() - margin;
    hi[a] = box.at("bounds_max")[a].get<double>() + margin;
  }
  int n = 0;
  const Rigid3d T_world_map = T_map_world.Inverse();
  for (const nlohmann::json& p : points) {
    const Eigen::Vector3d map(p.at("position")[0].get<double>(), p.at("position")[1].get<double>(),
                              p.at("position")[2].get<double>());
    const Eigen::Vector3d world = T_world_map * map;
    n += (world.array() >= lo.array()).all() && (world.array() <= hi.array()).all();
  }
  return n;
}

// Restore mapping on a changed room (rrslam-synth --change moved-box: one
// box moved, one added): the map of the original room is loaded, tracked
// and mapped on; the saved map gains points on the added box and on the
// moved box's new place, and loses the moved box's points at its old place
// (rrslam-mapstore diff). Every frame is tracked, with no jump where the
// changed part comes into view.
TEST_F(MapPipelineTest, RestoreMappingReplacesAMovedBox) {
  const fs::path changed = path("changed");
  const auto synth =
      testing::RunTool("synth", "--quiet --out " + Quote(changed) +
                                    " --width 320 --height 240 --trajectory loop --frames " +
                                    std::to_string(kFrames) + " --seed 3 --change moved-box");
  ASSERT_EQ(synth.exit_code, 0) << synth.output;
  const fs::path out = path("changed-track"), updated = path("changed.rrm");
  const auto r = testing::RunTool("track", "--quiet --sequence " + Quote(changed) + " --settings " +
                                               Quote(settings()) + " --vocab " + Quote(vocab()) +
                                               " --out " + Quote(out) + " --load-map " +
                                               Quote(map()) + " --save-map " + Quote(updated));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const nlohmann::json run = ReadJson(out / "run.json");
  EXPECT_EQ(run.at("counts").at("tracked").get<int>(), kFrames);
  EXPECT_GT(run.at("map").at("changed_points_culled").get<int>(), 0);

  // No jump: frame-to-frame motion as the ground truth's within 1 cm.
  const Trajectory gt = ReadTumTrajectory(changed / "groundtruth.txt");
  const Trajectory est = ReadTumTrajectory(out / "CameraTrajectory.txt");
  ASSERT_EQ(est.size(), gt.size());
  for (size_t k = 1; k < est.size(); ++k) {
    const double step_est =
        (est[k].T_world_cam.translation - est[k - 1].T_world_cam.translation).norm();
    const double step_gt =
        (gt[k].T_world_cam.translation - gt[k - 1].T_world_cam.translation).norm();
    EXPECT_NEAR(step_est, step_gt, 0.01) << "frame " << k;
  }

  const fs::path report = path("diff.json");
  const auto diff = testing::RunTool("mapstore", "diff " + Quote(map()) + " " + Quote(updated) +
                                                     " --radius 0.05 --json " + Quote(report));
  ASSERT_EQ(diff.exit_code, 0) << diff.output;
  const nlohmann::json d = ReadJson(report);
  const nlohmann::json change = ReadJson(changed / "synth.json").at("scene_change");
  // The map's world is the first camera: T_map_world = T_cam0_world.
  const Rigid3d T_map_world = gt.front().T_world_cam.Inverse();
  const nlohmann::json& added = d.at("map_points").at("added");
  const nlohmann::json& removed = d.at("map_points").at("removed");
  const int on_new_box = PointsIn(added, change.at("added")[0], T_map_world, 0.05);
  const int at_new_place = PointsIn(added, change.at("moved")[0].at("to"), T_map_world, 0.05);
  const int old_place_removed =
      PointsIn(removed, change.at("moved")[0].at("from"), T_map_world, 0.05);
  std::cerr << "restore mapping: " << added.size() << " points added (" << on_new_box
            << " on the new box, " << at_new_place << " at the moved box's new place), "
            << removed.size() << " removed (" << old_place_removed << " at its old place)\n";
  // The loop sees the moved box's places well, the added crate at its
  // edge: points on the changed places together.
  EXPECT_GE(on_new_box + at_new_place, 20);
  EXPECT_GE(old_place_removed, 20);
  // Most points removed were at the old place, not elsewhere.
  EXPECT_GE(old_place_removed, 0.6 * static_cast<double>(removed.size()));
}

// Issue 34: a cold start from a view that no mapped frame shares. Frame 32
// of the same room's `rotation` trajectory looks over 40 degrees away from
// every frame of the mapped loop; localization only relocalizes it at once
// (the direct stage: the bag-of-words shortlist alone finds no pose there)
// and the pose is the ground truth's in the map's frame (the loop's first
// camera) within the map's own accuracy.
TEST_F(MapPipelineTest, ColdStartFromAViewFortyDegreesFromEveryMappedFrame) {
  constexpr int kStart = 32;
  const fs::path turn = path("rotation");
  const auto synth = testing::RunTool(
      "synth", "--quiet --out " + Quote(turn) +
                   " --width 320 --height 240 --trajectory rotation --frames 120 --seed 3");
  ASSERT_EQ(synth.exit_code, 0) << synth.output;
  const Trajectory loop = ReadTumTrajectory(seq() / "groundtruth.txt");
  const Trajectory views = ReadTumTrajectory(turn / "groundtruth.txt");
  ASSERT_GT(views.size(), static_cast<size_t>(kStart));
  const StampedPose& view = views[kStart];
  // Optical axes' angle to every mapped frame.
  const Eigen::Vector3d axis = view.T_world_cam.rotation * Eigen::Vector3d::UnitZ();
  double nearest = M_PI;
  for (const StampedPose& p : loop) {
    const Eigen::Vector3d a = p.T_world_cam.rotation * Eigen::Vector3d::UnitZ();
    nearest = std::min(nearest, std::acos(std::clamp(axis.dot(a), -1.0, 1.0)));
  }
  ASSERT_GT(nearest * 180 / M_PI, 40.0);

  const fs::path out = path("cold-start-40");
  const auto r = testing::RunTool(
      "track",
      "--quiet --sequence " + Quote(turn) + " --settings " + Quote(turn / "settings.yaml") +
          " --vocab " + Quote(vocab()) + " --out " + Quote(out) + " --load-map " + Quote(map()) +
          " --localization-only --first-frame " + std::to_string(kStart) + " --max-frames 2");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const nlohmann::json run = ReadJson(out / "run.json");
  EXPECT_EQ(run.at("startup").at("first_pose_frame").get<int>(), kStart);
  const nlohmann::json& attempt = run.at("relocalization_attempts").at(0);
  EXPECT_FALSE(attempt.at("stage").get<std::string>().empty()) << attempt.dump();
  EXPECT_GE(attempt.at("inliers").get<int>(), 50) << attempt.dump();

  const Trajectory localized = ReadTumTrajectory(out / "CameraTrajectory.txt");
  ASSERT_FALSE(localized.empty());
  ASSERT_NEAR(localized.front().timestamp, view.timestamp, 1e-6);
  const Rigid3d truth = loop.front().T_world_cam.Inverse() * view.T_world_cam;
  const Rigid3d& found = localized.front().T_world_cam;
  EXPECT_LT((found.translation - truth.translation).norm(), 0.05);
  EXPECT_LT(RotationAngle(found.rotation, truth.rotation) * 180 / M_PI, 2.0);
}

// The floor-aligned frame (rrslam-mapstore align-floor, render --frame
// floor): the room's floor is found from the keyframes' depth, stored in the
// map (which still verifies), and the floor-frame PLY names it.
TEST_F(MapPipelineTest, FloorOfTheRoomIsFoundAndStored) {
  const fs::path aligned = path("aligned.rrm");
  fs::copy_file(map(), aligned);
  auto r =
      testing::RunTool("mapstore", "align-floor " + Quote(aligned) + " --sequence " + Quote(seq()));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("floor found"), std::string::npos) << r.output;
  EXPECT_EQ(testing::RunTool("mapstore", "verify " + Quote(aligned)).exit_code, 0);
  const auto info = testing::RunTool("mapstore", "info --json " + Quote(aligned));
  EXPECT_NE(info.output.find("T_floor_map"), std::string::npos) << info.output;
  r = testing::RunTool("render", "ply --map " + Quote(aligned) + " --out " +
                                     Quote(path("floor.ply")) + " --frame floor");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const std::string ply = ReadFileToString(path("floor.ply"));
  EXPECT_NE(ply.substr(0, 1000).find("frame: floor (REP 103: z up"), std::string::npos);
}

// What a robot takes from the floor-aligned map: an OctoMap and a
// navigation grid of the room (every keyframe's camera stands over a free
// cell; the walls make occupied cells), and the other exports in the floor
// frame, each naming it.
TEST_F(MapPipelineTest, FloorFrameExportsAndTheNavigationGrid) {
  const fs::path aligned = path("aligned-exports.rrm");
  fs::copy_file(map(), aligned);
  const std::string inputs = " --sequence " + Quote(seq());
  auto r = testing::RunTool("mapstore", "align-floor " + Quote(aligned) + inputs);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const std::string map_flag = "--map " + Quote(aligned) + inputs;

  r = testing::RunTool("render", "octomap " + map_flag + " --out " + Quote(path("room.bt")));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(ReadFileToString(path("room.bt")).substr(0, 600).find("frame: floor"),
            std::string::npos);

  r = testing::RunTool("render", "grid " + map_flag + " --out " + Quote(path("grid.yaml")));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  int free = 0, occupied = 0, unknown = 0, over_free = 0, cameras = 0;
  const size_t at = r.output.find("grid: ");
  ASSERT_NE(at, std::string::npos) << r.output;
  ASSERT_EQ(std::sscanf(r.output.c_str() + r.output.find(": ", at + 6) + 2,
                        "%d free, %d occupied, %d unknown; %d of %d", &free, &occupied, &unknown,
                        &over_free, &cameras),
            5)
      << r.output;
  EXPECT_GT(cameras, 5);
  EXPECT_EQ(over_free, cameras) << r.output;
  EXPECT_GT(free, occupied) << r.output;
  EXPECT_GT(occupied, 100) << r.output;
  EXPECT_NE(ReadFileToString(path("grid.yaml")).find("image: grid.pgm\nmode: trinary\n"),
            std::string::npos);
  int width = 0, height = 0;
  const std::string pgm = ReadFileToString(path("grid.pgm"));
  ASSERT_EQ(std::sscanf(pgm.c_str(), "P5 %d %d 255", &width, &height), 2);
  EXPECT_EQ(width * height, free + occupied + unknown);
  EXPECT_TRUE(fs::exists(path("grid.png")));

  r = testing::RunTool("render",
                       "colmap " + map_flag + " --out " + Quote(path("colmap")) + " --frame floor");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(ReadFileToString(path("colmap") / "frame.txt").find("frame: floor"), std::string::npos);
  r = testing::RunTool("render", "html --map " + Quote(aligned) + " --out " +
                                     Quote(path("floor.html")) + " --frame floor");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(ReadFileToString(path("floor.html")).find("\"frame\":\"floor\""), std::string::npos);
  r = testing::RunTool("render", "dense " + map_flag + " --out " + Quote(path("dense.ply")) +
                                     " --voxel 0.04 --frame floor");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(ReadFileToString(path("dense.ply")).substr(0, 1500).find("frame: floor"),
            std::string::npos);
}

// Offline merge (rrslam-mapstore merge): the loop mapped as two maps, frames
// 0-69 and 50-119, each in its own world frame (its first frame's camera).
// Merged, the second moves into the first's frame, which is the whole-loop
// map's too (both start at frame 0): localized in the merged map, frames
// 50-119 get the whole-loop map's poses within 2 cm. A map of another room
// is refused with exit 75, a camera that differs with exit 65; no output is
// written either time.
TEST_F(MapPipelineTest, OfflineMergeWeldsTwoHalvesInTheFirstMapsFrame) {
  const fs::path a = path("first-half.rrm"), b = path("second-half.rrm");
  ASSERT_EQ(Track(path("first-half"), "--max-frames 70 --save-map " + Quote(a)).exit_code, 0);
  ASSERT_EQ(Track(path("second-half"), "--first-frame 50 --save-map " + Quote(b)).exit_code, 0);
  const std::string common =
      " --vocab " + Quote(vocab()) + " --settings " + Quote(settings()) + " --out ";
  const fs::path merged = path("merged.rrm");
  auto r =
      testing::RunTool("mapstore", "merge " + Quote(a) + " " + Quote(b) + common + Quote(merged));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("transform B -> A"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("points fused"), std::string::npos) << r.output;
  EXPECT_EQ(testing::RunTool("mapstore", "verify " + Quote(merged)).exit_code, 0);

  const fs::path out = path("merged-localization");
  r = Track(out, "--load-map " + Quote(merged) + " --localization-only --first-frame 50");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const Trajectory whole = ReadTumTrajectory(path("mapping") / "CameraTrajectory.txt");
  const Trajectory localized = ReadTumTrajectory(out / "CameraTrajectory.txt");
  ASSERT_EQ(localized.size(), static_cast<size_t>(kFrames - 50));
  double worst = 0;
  for (size_t k = 0; k < localized.size(); ++k) {
    ASSERT_NEAR(whole[50 + k].timestamp, localized[k].timestamp, 1e-6);
    worst = std::max(
        worst,
        (whole[50 + k].T_world_cam.translation - localized[k].T_world_cam.translation).norm());
  }
  EXPECT_LT(worst, 0.02);

  // Another room (another seed), same camera and vocabulary: no overlap.
  const fs::path other = path("other-room");
  ASSERT_EQ(testing::RunTool("synth", "--quiet --out " + Quote(other) +
                                          " --width 320 --height 240 --trajectory loop "
                                          "--frames 40 --seed 11")
                .exit_code,
            0);
  const fs::path c = path("other-room.rrm");
  r = testing::RunTool("track", "--quiet --sequence " + Quote(other) + " --settings " +
                                    Quote(settings()) + " --vocab " + Quote(vocab()) + " --out " +
                                    Quote(path("other-room-track")) + " --save-map " + Quote(c));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  r = testing::RunTool("mapstore",
                       "merge " + Quote(a) + " " + Quote(c) + common + Quote(path("none.rrm")));
  EXPECT_EQ(r.exit_code, 75) << r.output;
  EXPECT_NE(r.output.find("no overlap"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(path("none.rrm")));

  std::string yaml = ReadFileToString(settings());
  const size_t fx = yaml.find("Camera.fx:");
  ASSERT_NE(fx, std::string::npos);
  yaml.replace(fx, yaml.find('\n', fx) - fx, "Camera.fx: 300.0");
  testing::WriteTextFile(path("other-camera.yaml"), yaml);
  r = testing::RunTool("mapstore", "merge " + Quote(a) + " " + Quote(b) + " --vocab " +
                                       Quote(vocab()) + " --settings " +
                                       Quote(path("other-camera.yaml")) + " --out " +
                                       Quote(path("none.rrm")));
  EXPECT_EQ(r.exit_code, 65) << r.output;
  EXPECT_NE(r.output.find("Camera.fx"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(path("none.rrm")));
}

// Bad map inputs: one line naming the file and the problem, the documented
// exit code, and no output folder.
TEST_F(MapPipelineTest, BadMapsAreRefused) {
  const std::string bytes = ReadFileToString(map());
  testing::WriteTextFile(path("truncated.rrm"), bytes.substr(0, bytes.size() / 2));
  auto r = Track(path("bad1"), "--load-map " + Quote(path("truncated.rrm")));
  EXPECT_EQ(r.exit_code, 65) << r.output;
  EXPECT_NE(r.output.find("truncated.rrm"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(path("bad1")));

  r = Track(path("bad2"), "--load-map " + Quote(path("missing.rrm")));
  EXPECT_EQ(r.exit_code, 66) << r.output;
  fs::create_directories(path("folder.rrm"));  // A folder, not a map file.
  r = Track(path("bad3"), "--load-map " + Quote(path("folder.rrm")));
  EXPECT_EQ(r.exit_code, 66) << r.output;
  r = Track(path("bad4"), "--localization-only");
  EXPECT_EQ(r.exit_code, 64) << r.output;
  EXPECT_NE(r.output.find("--load-map"), std::string::npos) << r.output;

  // Another camera: the map names the setting that differs.
  std::string yaml = ReadFileToString(settings());
  const size_t fx = yaml.find("Camera.fx:");
  ASSERT_NE(fx, std::string::npos);
  yaml.replace(fx, yaml.find('\n', fx) - fx, "Camera.fx: 300.0");
  testing::WriteTextFile(path("other.yaml"), yaml);
  r = testing::RunTool("track", "--quiet --sequence " + Quote(seq()) + " --settings " +
                                    Quote(path("other.yaml")) + " --vocab " + Quote(vocab()) +
                                    " --out " + Quote(path("bad5")) + " --load-map " +
                                    Quote(map()));
  EXPECT_EQ(r.exit_code, 65) << r.output;
  EXPECT_NE(r.output.find("Camera.fx"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(path("bad5")));

  // Another vocabulary (a two-word DBoW2 tree): the map names both trees.
  std::string two_words = "2 1 0 0\n";
  for (int word = 0; word < 2; ++word) {
    two_words += "0 1 ";
    for (int b = 0; b < 32; ++b) two_words += std::to_string(word * 255) + " ";
    two_words += " 1\n";
  }
  testing::WriteTextFile(path("two.txt"), two_words);
  r = testing::RunTool("track", "--quiet --sequence " + Quote(seq()) + " --settings " +
                                    Quote(settings()) + " --vocab " + Quote(path("two.txt")) +
                                    " --out " + Quote(path("bad8")) + " --load-map " +
                                    Quote(map()));
  EXPECT_EQ(r.exit_code, 65) << r.output;
  EXPECT_NE(r.output.find("built with vocabulary tree"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(path("bad8")));

  // A sequence that never shows the mapped place (its images black): no
  // frame relocalizes, exit 75 and no output.
  const fs::path dark = path("dark");
  fs::create_directories(dark / "rgb");
  fs::create_directories(dark / "depth");
  {
    const RgbdSequence room = RgbdSequence::Open(seq());
    std::ofstream rgb_list(dark / "rgb.txt"), depth_list(dark / "depth.txt");
    for (int k = 0; k < 5; ++k) {
      const std::string name = std::to_string(k) + ".png";
      WritePng(dark / "rgb" / name, cv::Mat::zeros(240, 320, CV_8UC3));
      fs::copy_file(room.frame(k).depth_path, dark / "depth" / name);
      rgb_list << std::fixed << k / 30.0 << " rgb/" << name << "\n";
      depth_list << std::fixed << k / 30.0 << " depth/" << name << "\n";
    }
  }
  r = testing::RunTool("track", "--quiet --sequence " + Quote(dark) + " --settings " +
                                    Quote(settings()) + " --vocab " + Quote(vocab()) + " --out " +
                                    Quote(path("bad9")) + " --load-map " + Quote(map()) +
                                    " --localization-only");
  EXPECT_EQ(r.exit_code, 75) << r.output;
  EXPECT_NE(r.output.find("no frame relocalized"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(path("bad9")));

  // A --save-map that cannot be written fails before tracking, and an
  // existing map is never touched by a failed run.
  r = Track(path("bad6"), "--save-map " + Quote(path("no-such-folder") / "m.rrm"));
  EXPECT_EQ(r.exit_code, 73) << r.output;
  const std::string before = ReadFileToString(map());
  r = Track(path("bad7"),
            "--save-map " + Quote(map()) + " --load-map " + Quote(path("truncated.rrm")));
  EXPECT_EQ(r.exit_code, 65);
  EXPECT_EQ(ReadFileToString(map()), before);
}

}  // namespace
}  // namespace rrslam
