// End to end: the atlas of a restore-mapping session (issue 31,
// stages/track/module/atlas.h). The room's sweep (looking north) is mapped;
// a session on that map starts where the map is not (rrslam-synth's turn:
// looking east at the table), starts a new map after --new-map-after, turns
// north and is merged into the sweep's map.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>

#include "common/atomic_file.h"
#include "common/geometry.h"
#include "common/testing.h"
#include "common/trajectory.h"
#include "tests/room_pipeline.h"

namespace rrslam {
namespace {

namespace fs = std::filesystem;

using testing::Quote;
using testing::ReadJson;

class AtlasPipelineTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new testing::TempDir();
    testing::PrepareRoomSequence(dir_->path(), "--trajectory sweep --frames 150 --seed 3");
    if (HasFatalFailure()) return;
    auto r = testing::RunTool("synth", "--quiet --out " + Quote(path("turn")) +
                                           " --width 320 --height 240 --trajectory turn "
                                           "--frames 360 --seed 3");
    ASSERT_EQ(r.exit_code, 0) << r.output;
    r = Track(path("room"), path("mapping"), "--save-map " + Quote(map()));
    ASSERT_EQ(r.exit_code, 0) << r.output;
  }
  static void TearDownTestSuite() {
    delete dir_;
    dir_ = nullptr;
  }
  static fs::path path(const std::string& name) { return dir_->path() / name; }
  static fs::path map() { return path("sweep.rrm"); }

  static testing::CommandResult Track(const fs::path& seq, const fs::path& out,
                                      const std::string& extra) {
    return testing::RunTool("track", "--quiet --sequence " + Quote(seq) + " --settings " +
                                         Quote(seq / "settings.yaml") + " --vocab " +
                                         Quote(path("room.rrv")) + " --out " + Quote(out) + " " +
                                         extra);
  }

  static testing::TempDir* dir_;
};
testing::TempDir* AtlasPipelineTest::dir_ = nullptr;

TEST_F(AtlasPipelineTest, OffMapSessionStartsANewMapAndMergesIntoTheLoadedOne) {
  const fs::path out = path("merged-session");
  const auto r = Track(path("turn"), out, "--load-map " + Quote(map()));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const nlohmann::json run = ReadJson(out / "run.json");
  const nlohmann::json& atlas = run.at("atlas");
  EXPECT_EQ(atlas.at("maps_started").get<int>(), 1) << atlas.dump();
  ASSERT_EQ(atlas.at("merges").size(), 1u) << atlas.dump();
  const nlohmann::json& merge = atlas.at("merges").at(0);
  EXPECT_LE(merge.at("timestamp").get<double>() - merge.at("first_match_timestamp").get<double>(),
            1.0)
      << merge.dump();
  EXPECT_FALSE(atlas.at("unmerged").get<bool>());
  // Only the frames before the new map are lost.
  const double new_map = atlas.at("new_map_timestamp").get<double>();
  for (const auto& t : run.at("lost_timestamps")) EXPECT_LE(t.get<double>(), new_map);

  // Every frame, those before the merge too, in the sweep's map frame (the
  // sweep's first camera).
  const Trajectory sweep = ReadTumTrajectory(path("room") / "groundtruth.txt");
  const Trajectory truth = ReadTumTrajectory(path("turn") / "groundtruth.txt");
  const Trajectory estimate = ReadTumTrajectory(out / "CameraTrajectory.txt");
  ASSERT_GT(estimate.size(), truth.size() / 2);
  const Rigid3d T_map_world = sweep.front().T_world_cam.Inverse();
  double sum = 0;
  size_t k = 0;
  for (const StampedPose& e : estimate) {
    while (k < truth.size() && truth[k].timestamp < e.timestamp - 1e-6) ++k;
    ASSERT_LT(k, truth.size());
    sum += ((T_map_world * truth[k].T_world_cam).translation - e.T_world_cam.translation)
               .squaredNorm();
  }
  EXPECT_LT(std::sqrt(sum / estimate.size()), 0.02);
}

TEST_F(AtlasPipelineTest, SessionThatNeverMeetsTheMapKeepsTrackingAndKeepsTheLoadedMap) {
  const fs::path out = path("unmerged-session"), saved = path("saved.rrm");
  const auto r =
      Track(path("turn"), out,
            "--load-map " + Quote(map()) + " --save-map " + Quote(saved) + " --max-frames 60");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const nlohmann::json run = ReadJson(out / "run.json");
  EXPECT_EQ(run.at("atlas").at("maps_started").get<int>(), 1);
  EXPECT_TRUE(run.at("atlas").at("merges").empty());
  EXPECT_TRUE(run.at("atlas").at("unmerged").get<bool>());
  const double new_map = run.at("atlas").at("new_map_timestamp").get<double>();
  for (const auto& t : run.at("lost_timestamps")) EXPECT_LE(t.get<double>(), new_map);
  EXPECT_LT(run.at("counts").at("lost").get<int>(), 60);
  // The file keeps the loaded map as it was and the new map beside it, in
  // its own frame (format 1.1).
  const nlohmann::json& map = run.at("map");
  EXPECT_EQ(map.at("keyframes_culled").get<int>(), 0);
  EXPECT_EQ(map.at("map_points_culled").get<int>(), 0);
  EXPECT_EQ(map.at("other_maps_saved").get<int>(), 1);
  const auto verify = testing::RunTool("mapstore", "verify " + Quote(saved));
  ASSERT_EQ(verify.exit_code, 0) << verify.output;
  EXPECT_NE(verify.output.find(": ok (" + std::to_string(map.at("keyframes_loaded").get<int>()) +
                               " keyframes"),
            std::string::npos)
      << verify.output;
  EXPECT_NE(verify.output.find("other map 1 (its own world frame): " +
                               std::to_string(run.at("counts").at("keyframes").get<int>()) +
                               " keyframes"),
            std::string::npos)
      << verify.output;

  // The next session on that file meets the loaded map: merged, and the
  // other map is carried along, not lost.
  const fs::path next = path("next-session"), next_map = path("next.rrm");
  const auto again =
      Track(path("turn"), next, "--load-map " + Quote(saved) + " --save-map " + Quote(next_map));
  ASSERT_EQ(again.exit_code, 0) << again.output;
  const nlohmann::json next_run = ReadJson(next / "run.json");
  EXPECT_EQ(next_run.at("atlas").at("merges").size(), 1u);
  EXPECT_EQ(next_run.at("map").at("other_maps_loaded").get<int>(), 1);
  EXPECT_EQ(next_run.at("map").at("other_maps_saved").get<int>(), 1);
}

TEST_F(AtlasPipelineTest, NegativeNewMapAfterWaitsForTheLoadedMapAsOrbSlam2) {
  const auto r = Track(path("turn"), path("waiting"),
                       "--load-map " + Quote(map()) + " --new-map-after -1 --max-frames 60");
  // Nothing relocalizes in 60 frames looking away from the map: the run fails
  // as before the atlas, naming the map.
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find("no frame relocalized"), std::string::npos) << r.output;
}

}  // namespace
}  // namespace rrslam
