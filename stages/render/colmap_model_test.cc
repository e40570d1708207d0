#include "stages/render/colmap_model.h"

#include <gtest/gtest.h>

#include "common/atomic_file.h"
#include "common/errors.h"
#include "common/testing.h"
#include "stages/mapstore/map_join.h"
#include "stages/render/render_test_util.h"

namespace rrslam {
namespace {

class ColmapModelTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const std::vector<Rigid3d> poses = {
        Rigid3d::Identity(),
        Rigid3d(Eigen::Quaterniond(Eigen::AngleAxisd(0.1, Eigen::Vector3d::UnitY())),
                Eigen::Vector3d(0.5, 0.01, -0.02))};
    std::vector<Eigen::Vector3d> points;
    for (int i = 0; i < 20; ++i) points.emplace_back(-1.0 + 0.1 * i, 0.05 * (i % 5), 3.0);
    map_ = testing::MakeKnownMap(poses, points);
    names_ = {"a.png", "b.png"};
    colours_.assign(map_.map_points.size(), {10, 20, 30});
  }
  MapData map_;
  std::vector<std::string> names_;
  std::vector<std::array<uint8_t, 3>> colours_;
  testing::TempDir dir_;
};

// COLMAP's pixels start at 0.5 and its poses are world-to-camera; every
// observation of the map is in the model, and points project onto their
// keypoints (the known map's keypoints are exact projections).
TEST_F(ColmapModelTest, ModelHoldsThePosesKeypointsAndTracksOfTheMap) {
  const ColmapModel m = ColmapModelOf(map_, names_, colours_);
  ASSERT_EQ(m.cameras.size(), 1u);
  EXPECT_EQ(m.cameras[0].model, "PINHOLE");
  EXPECT_DOUBLE_EQ(m.cameras[0].params[2], map_.camera.cx + 0.5);
  ASSERT_EQ(m.images.size(), 2u);
  EXPECT_EQ(m.images[1].name, "b.png");
  const Rigid3d T = RigidOf(map_.keyframes[1].T_cam_world);
  EXPECT_LT((m.images[1].T_cam_world.translation - T.translation).norm(), 1e-15);
  const KeyFrameRecord& kf = map_.keyframes[0];
  ASSERT_EQ(m.images[0].points2d.size(), kf.keypoints.size());
  EXPECT_DOUBLE_EQ(m.images[0].points2d[0][0], kf.keypoints[0].pixel.x() + 0.5);
  ASSERT_EQ(m.points.size(), map_.map_points.size());
  for (const ColmapPoint& p : m.points) {
    EXPECT_LT(p.error, 1e-3);
    for (const auto& [image, index] : p.track) {
      EXPECT_EQ(m.images[image - 1].point3d_ids[index], static_cast<int64_t>(p.id));
    }
  }
}

TEST_F(ColmapModelTest, TextAndBinaryRoundTripKeepPosesToANanometre) {
  const ColmapModel m = ColmapModelOf(map_, names_, colours_);
  for (bool binary : {false, true}) {
    const std::filesystem::path dir = dir_.path() / (binary ? "bin" : "txt");
    std::filesystem::create_directories(dir);
    WriteColmapModel(m, dir, binary);
    const ColmapModel back = ReadColmapModel(dir, binary);
    ASSERT_EQ(back.images.size(), m.images.size());
    for (size_t i = 0; i < m.images.size(); ++i) {
      EXPECT_EQ(back.images[i].name, m.images[i].name);
      EXPECT_LT(
          (back.images[i].T_cam_world.translation - m.images[i].T_cam_world.translation).norm(),
          1e-9);
      EXPECT_LT(
          back.images[i].T_cam_world.rotation.angularDistance(m.images[i].T_cam_world.rotation),
          1e-9);
      EXPECT_EQ(back.images[i].point3d_ids, m.images[i].point3d_ids);
    }
    ASSERT_EQ(back.points.size(), m.points.size());
    EXPECT_EQ(back.points[3].track, m.points[3].track);
    EXPECT_EQ(back.points[3].rgb, m.points[3].rgb);
    EXPECT_EQ(back.cameras[0].params, m.cameras[0].params);
  }
}

TEST_F(ColmapModelTest, MissingOrTruncatedFilesAreRefused) {
  EXPECT_THROW(ReadColmapModel(dir_.path() / "none", false), NoInputError);
  const ColmapModel m = ColmapModelOf(map_, names_, colours_);
  WriteColmapModel(m, dir_.path(), true);
  const std::string bytes = ReadFileToString(dir_.path() / "images.bin");
  testing::WriteTextFile(dir_.path() / "images.bin", bytes.substr(0, bytes.size() / 2));
  EXPECT_THROW(ReadColmapModel(dir_.path(), true), DataError);
}

}  // namespace
}  // namespace rrslam
