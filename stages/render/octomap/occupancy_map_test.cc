#include "stages/render/octomap/occupancy_map.h"

#include <gtest/gtest.h>
#include <octomap/OcTree.h>

#include <CLI/CLI.hpp>

#include "common/atomic_file.h"
#include "common/errors.h"
#include "common/testing.h"
#include "stages/render/octomap/box_room_test_util.h"

namespace rrslam {
namespace {

std::unique_ptr<octomap::OcTree> RoomTree(const DepthIntegrationOptions& options,
                                          IntegrationStats* stats, int views = 8) {
  const testing::BoxRoom room;
  std::vector<Rigid3d> poses;
  for (int k = 0; k < views; ++k) poses.push_back(room.CameraPose(k, views));
  return IntegrateDepth(
      options, room.camera, poses, [&](size_t i) { return room.Depth(poses[i]); }, stats);
}

bool Occupied(const octomap::OcTree& tree, double x, double y, double z) {
  const octomap::OcTreeNode* node = tree.search(x, y, z);
  return node != nullptr && tree.isNodeOccupied(node);
}

bool Free(const octomap::OcTree& tree, double x, double y, double z) {
  const octomap::OcTreeNode* node = tree.search(x, y, z);
  return node != nullptr && !tree.isNodeOccupied(node);
}

TEST(IntegrateDepth, SurfacesOccupiedAndTheAirBeforeThemFree) {
  IntegrationStats stats;
  const auto tree = RoomTree(DepthIntegrationOptions{}, &stats);
  EXPECT_EQ(stats.keyframes, 8u);
  EXPECT_EQ(stats.rays, 8u * 160 * 120);
  EXPECT_GT(stats.occupied_leaves, 0u);
  EXPECT_EQ(stats.nodes, tree->size());
  // Walls (x = +-2), floor (z = 0) and the table top (z = 0.75) end rays.
  EXPECT_TRUE(Occupied(*tree, 2.02, 0.0, 1.0) || Occupied(*tree, 1.98, 0.0, 1.0));
  EXPECT_TRUE(Occupied(*tree, -2.02, 0.3, 0.5) || Occupied(*tree, -1.98, 0.3, 0.5));
  EXPECT_TRUE(Occupied(*tree, -1.0, 0.7, 0.02) || Occupied(*tree, -1.0, 0.7, -0.02));
  EXPECT_TRUE(Occupied(*tree, 1.1, 0.0, 0.77) || Occupied(*tree, 1.1, 0.0, 0.73));
  // The air between the cameras and the walls.
  EXPECT_TRUE(Free(*tree, 1.0, 0.0, 1.1));
  EXPECT_TRUE(Free(*tree, -1.5, -0.5, 0.8));
  // Under the table and behind the walls nothing is known.
  EXPECT_EQ(tree->search(1.1, 0.0, 0.3), nullptr);
  EXPECT_EQ(tree->search(2.5, 0.0, 1.0), nullptr);
}

TEST(IntegrateDepth, MaxRangeClearsWithoutMarking) {
  DepthIntegrationOptions options;
  options.max_range = 0.6;  // Every surface is farther (the table edge 0.92 m).
  IntegrationStats stats;
  const auto tree = RoomTree(options, &stats);
  EXPECT_EQ(stats.occupied_leaves, 0u);
  EXPECT_TRUE(Free(*tree, 0.45, 0.0, 1.1));
  EXPECT_EQ(tree->search(1.8, 0.0, 1.0), nullptr);
}

TEST(IntegrateDepth, RefusesImagesOfAnotherSizeAndNoDepth) {
  const testing::BoxRoom room;
  IntegrationStats stats;
  const std::vector<Rigid3d> poses = {room.CameraPose(0, 1)};
  EXPECT_THROW(IntegrateDepth(
                   DepthIntegrationOptions{}, room.camera, poses,
                   [](size_t) { return cv::Mat(10, 10, CV_32FC1, 1.0f); }, &stats),
               DataError);
  EXPECT_THROW(IntegrateDepth(
                   DepthIntegrationOptions{}, room.camera, poses,
                   [](size_t) { return cv::Mat(120, 160, CV_32FC1, 0.0f); }, &stats),
               DataError);
}

// The file as OctoMap reads it: the library's reader gets the same tree
// back, and octomap-tools' edit_octree (Debian's octomap-tools; skipped where
// absent) reads it, past rrslam's header comments, with the same node count.
TEST(WriteOctree, OctoMapReadsTheFile) {
  IntegrationStats stats;
  const auto tree = RoomTree(DepthIntegrationOptions{}, &stats);
  testing::TempDir dir;
  const std::filesystem::path path = dir.path() / "room.bt";
  {
    AtomicOutput output(path);
    WriteOctree(*tree, {"producer test", "frame: floor"}, &output);
  }
  const std::string bytes = ReadFileToString(path);
  EXPECT_EQ(bytes.rfind("# Octomap OcTree binary file\n# producer test\n# frame: floor\n", 0), 0u);
  octomap::OcTree back(0.1);
  ASSERT_TRUE(back.readBinary(path.string()));
  EXPECT_EQ(back.size(), tree->size());
  EXPECT_DOUBLE_EQ(back.getResolution(), 0.05);
  EXPECT_TRUE(Occupied(back, 1.1, 0.0, 0.77) || Occupied(back, 1.1, 0.0, 0.73));

  if (testing::RunCommand("command -v edit_octree > /dev/null").exit_code != 0) {
    GTEST_SKIP() << "octomap-tools is not installed (scripts/install-deps.sh all installs it)";
  }
  const auto edit = testing::RunCommand("edit_octree -o " + (dir.path() / "copy.bt").string() +
                                        " " + path.string() + " 2>&1");
  ASSERT_EQ(edit.exit_code, 0) << edit.output;
  EXPECT_NE(edit.output.find("Writing " + std::to_string(tree->size()) + " nodes"),
            std::string::npos)
      << edit.output;
}

TEST(OctomapOptions, Checks) {
  OctomapOptions o;
  std::string why;
  EXPECT_FALSE(o.Check(&why));
  o.input.map = "m.rrm";
  o.input.sequence = "seq";
  o.out = "room.bt";
  EXPECT_TRUE(o.Check(&why)) << why;
  EXPECT_EQ(o.frame, "floor");
  OctomapOptions bad = o;
  bad.out = "room.ot";
  EXPECT_FALSE(bad.Check(&why));
  EXPECT_NE(why.find("must be a .bt file"), std::string::npos) << why;
  bad = o;
  bad.frame = "ceiling";
  EXPECT_FALSE(bad.Check(&why));
  EXPECT_NE(why.find("--frame ceiling"), std::string::npos) << why;
  bad = o;
  bad.integration.max_range = 0;
  EXPECT_FALSE(bad.Check(&why));
  EXPECT_NE(why.find("--max-range"), std::string::npos) << why;
  bad = o;
  bad.integration.pixel_stride = 0;
  EXPECT_FALSE(bad.Check(&why));
  EXPECT_NE(why.find("--pixel-stride"), std::string::npos) << why;
  bad = o;
  bad.integration.resolution = 2;
  EXPECT_FALSE(bad.Check(&why));
  bad = o;
  bad.input.map = "m.bt";
  bad.out = "m.bt";
  EXPECT_FALSE(bad.Check(&why));
}

TEST(OctomapOptions, BindsFlags) {
  CLI::App app;
  OctomapOptions o;
  BindOctomapOptions(&app, &o);
  app.parse("--map m --sequence s --out a.bt --frame camera --resolution 0.1 --max-range 3.5");
  EXPECT_DOUBLE_EQ(o.integration.resolution, 0.1);
  EXPECT_DOUBLE_EQ(o.integration.max_range, 3.5);
  EXPECT_EQ(o.frame, "camera");
  EXPECT_EQ(o.ToJson()["integration"]["resolution"], 0.1);
}

}  // namespace
}  // namespace rrslam
