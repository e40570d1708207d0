#include "stages/synth/scene.h"

#include <gtest/gtest.h>

#include <cmath>
#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>
#include <set>

#include "stages/synth/random.h"
#include "stages/synth/texture.h"

namespace rrslam::synth {
namespace {

// A bare 4 x 3 x 2.5 m room with one 1 m cube on the floor, coarse textures.
Scene SmallScene(uint64_t seed = 0) {
  Box room;
  room.name = "room";
  room.centre_world = Eigen::Vector3d(0, 0, 1.25);
  room.size = Eigen::Vector3d(4, 3, 2.5);
  room.inside = true;
  room.materials.fill(Material::kWall);
  std::vector<Box> boxes = {
      room, Box::Object("cube", Eigen::Vector3d(1, 0, 0.5), Eigen::Vector3d(1, 1, 1),
                        Material::kCardboard, 0.0, kFaceNegZ)};
  SceneOptions options;
  options.seed = seed;
  options.texel_size = 0.02;
  return Scene(boxes, options);
}

TEST(Scene, SurfacesAreOrthonormalRectanglesFacingTheirVisibleSide) {
  SceneOptions options;
  options.texel_size = 0.05;
  const Scene scene = Scene::StandardRoom(options);
  ASSERT_GT(scene.surfaces().size(), 60u);
  std::set<std::string> names;
  for (size_t i = 0; i < scene.surfaces().size(); ++i) {
    const Surface& s = scene.surface(static_cast<int>(i));
    EXPECT_EQ(s.id, static_cast<int>(i));
    EXPECT_TRUE(names.insert(s.name).second) << "duplicate " << s.name;
    EXPECT_NEAR(s.axis_a_world.norm(), 1.0, 1e-12);
    EXPECT_NEAR(s.axis_b_world.norm(), 1.0, 1e-12);
    EXPECT_NEAR(s.axis_a_world.dot(s.axis_b_world), 0.0, 1e-12);
    EXPECT_TRUE(s.normal_world.isApprox(s.axis_b_world.cross(s.axis_a_world), 1e-12));
    EXPECT_GT(s.size_a, 0.0);
    EXPECT_GT(s.size_b, 0.0);
    for (int k = 0; k < 4; ++k) {
      const Eigen::Vector3d c = s.Corner(k);
      EXPECT_TRUE(c.x() >= -3 - 1e-9 && c.x() <= 3 + 1e-9 && c.y() >= -2.5 - 1e-9 &&
                  c.y() <= 2.5 + 1e-9 && c.z() >= -1e-9 && c.z() <= 3 + 1e-9)
          << s.name;
    }
    const MipTexture& texture = scene.texture(s.id);
    // Whole texels cover the surface (at least 2 x 2).
    EXPECT_GE(texture.width() * options.texel_size, s.size_a - 1e-12) << s.name;
    EXPECT_LT(texture.width() * options.texel_size, s.size_a + 2 * options.texel_size) << s.name;
    EXPECT_GE(texture.height() * options.texel_size, s.size_b - 1e-12) << s.name;
    EXPECT_LT(texture.height() * options.texel_size, s.size_b + 2 * options.texel_size) << s.name;
  }
  EXPECT_TRUE(names.count("room.-z") && names.count("room.+z") && names.count("table.top.+z"));
  // Seen from the visible side, a points right and b down: the floor's
  // texture is not mirrored when looking down at it.
  const Surface& floor = scene.surface(5);  // The room's faces: +x -x +y -y +z -z.
  EXPECT_EQ(floor.name, "room.-z");
  EXPECT_TRUE(floor.normal_world.isApprox(Eigen::Vector3d::UnitZ()));
}

TEST(Scene, RayCastFindsTheFirstVisibleSurface) {
  const Scene scene = SmallScene();
  const Eigen::Vector3d centre(-1, 0, 1.2);
  // Down to the floor, up to the ceiling.
  auto hit = scene.RayCast(centre, -Eigen::Vector3d::UnitZ());
  ASSERT_TRUE(hit);
  EXPECT_EQ(scene.surface(hit->surface_id).name, "room.-z");
  EXPECT_NEAR(hit->distance, 1.2, 1e-12);
  hit = scene.RayCast(centre, Eigen::Vector3d(0, 0, 2));  // Unnormalized: distance in its units.
  ASSERT_TRUE(hit);
  EXPECT_EQ(scene.surface(hit->surface_id).name, "room.+z");
  EXPECT_NEAR(hit->distance, 0.65, 1e-12);
  // Towards +x the cube's -x face is 1.5 m away, in front of the wall.
  hit = scene.RayCast(Eigen::Vector3d(-1, 0, 0.5), Eigen::Vector3d::UnitX());
  ASSERT_TRUE(hit);
  EXPECT_EQ(scene.surface(hit->surface_id).name, "cube.-x");
  EXPECT_NEAR(hit->distance, 1.5, 1e-12);
  EXPECT_TRUE(hit->point_world.isApprox(Eigen::Vector3d(0.5, 0, 0.5), 1e-12));
  // Texture coordinates locate the same point.
  const Surface& s = scene.surface(hit->surface_id);
  EXPECT_TRUE((s.origin_world + hit->a * s.axis_a_world + hit->b * s.axis_b_world)
                  .isApprox(hit->point_world, 1e-12));
  // Above the cube the ray goes on to the wall.
  hit = scene.RayCast(Eigen::Vector3d(-1, 0, 1.5), Eigen::Vector3d::UnitX());
  ASSERT_TRUE(hit);
  EXPECT_EQ(scene.surface(hit->surface_id).name, "room.+x");
  EXPECT_NEAR(hit->distance, 3.0, 1e-12);
  // min_distance skips nearer hits.
  hit = scene.RayCast(Eigen::Vector3d(-1, 0, 0.5), Eigen::Vector3d::UnitX(), 2.0);
  ASSERT_TRUE(hit);
  EXPECT_EQ(scene.surface(hit->surface_id).name, "room.+x");
  // One-sided: from above the room, the ceiling's back is not hit.
  hit = scene.RayCast(Eigen::Vector3d(-1, 0, 10), -Eigen::Vector3d::UnitZ());
  ASSERT_TRUE(hit);
  EXPECT_EQ(scene.surface(hit->surface_id).name, "room.-z");
  // From outside, looking away: nothing.
  EXPECT_FALSE(scene.RayCast(Eigen::Vector3d(-1, 0, 10), Eigen::Vector3d::UnitZ()));
}

TEST(Scene, RejectsUnreasonableTexelSizes) {
  SceneOptions options;
  options.texel_size = 0;
  EXPECT_THROW(Scene(StandardRoomBoxes(), options), std::invalid_argument);
  options.texel_size = 0.2;
  EXPECT_THROW(Scene(StandardRoomBoxes(), options), std::invalid_argument);
}

TEST(Scene, DistancesToRectangles) {
  const Scene scene = SmallScene();
  EXPECT_NEAR(scene.DistanceToNearestSurface(Eigen::Vector3d(-1, 0, 1.2)), 1.0, 1e-12);  // -x wall.
  // Diagonally off the cube's top edge: distance to the edge, not to the plane.
  EXPECT_NEAR(scene.DistanceToNearestSurface(Eigen::Vector3d(0.2, 0, 1.3)), std::hypot(0.3, 0.3),
              1e-12);
}

TEST(Scene, TexturesDependOnlyOnTheSeedNotOnThreads) {
  Box room;
  room.name = "room";
  room.size = Eigen::Vector3d(2, 1.5, 1);
  room.inside = true;
  room.materials = {Material::kWall, Material::kFloor,     Material::kCeiling,
                    Material::kWood, Material::kCardboard, Material::kPoster};
  SceneOptions options;
  options.texel_size = 0.01;
  options.num_threads = 1;
  const Scene a({room}, options);
  options.num_threads = 3;
  const Scene b({room}, options);
  options.seed = 1;
  const Scene c({room}, options);
  for (size_t i = 0; i < a.surfaces().size(); ++i) {
    const cv::Mat ta = a.texture(i).LevelImage(0), tb = b.texture(i).LevelImage(0),
                  tc = c.texture(i).LevelImage(0);
    EXPECT_EQ(cv::norm(ta, tb, cv::NORM_INF), 0.0) << i;
    EXPECT_GT(cv::norm(ta, tc, cv::NORM_L1) / ta.total(), 10.0) << i;
  }
}

TEST(Texture, EveryMaterialIsRichInCornersAtSeveralScales) {
  for (Material m : {Material::kWall, Material::kFloor, Material::kCeiling, Material::kWood,
                     Material::kCardboard, Material::kPainted, Material::kPoster}) {
    const cv::Mat image = GenerateTexture(m, 1.2, 0.9, 0.003, 42);
    ASSERT_EQ(image.type(), CV_8UC3);
    ASSERT_EQ(image.cols, 400);
    ASSERT_EQ(image.rows, 300);
    cv::Mat gray;
    cv::cvtColor(image, gray, cv::COLOR_BGR2GRAY);
    cv::Scalar mean, stddev;
    cv::meanStdDev(gray, mean, stddev);
    EXPECT_GT(stddev[0], 12.0) << MaterialName(m);
    EXPECT_GT(mean[0], 40.0) << MaterialName(m);
    EXPECT_LT(mean[0], 225.0) << MaterialName(m);
    // Corners at full resolution and 4x coarser (as seen from 4x farther).
    for (double scale : {1.0, 0.25}) {
      cv::Mat level;
      cv::resize(gray, level, cv::Size(), scale, scale, cv::INTER_AREA);
      std::vector<cv::KeyPoint> corners;
      cv::FAST(level, corners, 20, true);
      const double per_kilopixel = 1000.0 * corners.size() / level.total();
      EXPECT_GT(per_kilopixel, scale == 1.0 ? 2.0 : 4.0) << MaterialName(m) << " x" << scale;
    }
  }
}

TEST(Texture, IsDeterministic) {
  const cv::Mat a = GenerateTexture(Material::kPoster, 0.5, 0.4, 0.004, 3);
  const cv::Mat b = GenerateTexture(Material::kPoster, 0.5, 0.4, 0.004, 3);
  const cv::Mat c = GenerateTexture(Material::kPoster, 0.5, 0.4, 0.004, 4);
  EXPECT_EQ(cv::norm(a, b, cv::NORM_INF), 0.0);
  EXPECT_GT(cv::norm(a, c, cv::NORM_INF), 0.0);
}

TEST(FractalNoise, IsNormalizedAndDeterministic) {
  Rng rng1(5), rng2(5);
  const cv::Mat a = FractalNoise(300, 200, std::vector<float>(7, 1.0f), rng1);
  const cv::Mat b = FractalNoise(300, 200, std::vector<float>(7, 1.0f), rng2);
  ASSERT_EQ(a.type(), CV_32FC1);
  ASSERT_EQ(a.size(), cv::Size(300, 200));
  EXPECT_EQ(cv::norm(a, b, cv::NORM_INF), 0.0);
  cv::Scalar mean, stddev;
  cv::meanStdDev(a, mean, stddev);
  EXPECT_NEAR(mean[0], 0.0, 1e-4);
  EXPECT_NEAR(stddev[0], 1.0, 1e-4);
  // Coarse-only noise is smooth: neighbours are strongly correlated.
  Rng rng3(5);
  std::vector<float> coarse(7, 0.0f);
  coarse[6] = coarse[5] = 1.0f;
  const cv::Mat smooth = FractalNoise(300, 200, coarse, rng3);
  double diff = 0;
  for (int r = 0; r < 200; ++r) {
    for (int c = 1; c < 300; ++c)
      diff += std::fabs(smooth.at<float>(r, c) - smooth.at<float>(r, c - 1));
  }
  EXPECT_LT(diff / (200 * 299), 0.1);
}

TEST(MipTexture, LevelsAreBoxAveragesDownToOneTexel) {
  cv::Mat image(5, 8, CV_8UC3);
  for (int r = 0; r < image.rows; ++r) {
    for (int c = 0; c < image.cols; ++c) image.at<cv::Vec3b>(r, c) = cv::Vec3b(r * 40, c * 30, 100);
  }
  const MipTexture texture(image, 0.01);
  ASSERT_EQ(texture.num_levels(), 4);  // 8x5, 4x3, 2x2, 1x1.
  EXPECT_EQ(texture.LevelImage(1).size(), cv::Size(4, 3));
  EXPECT_EQ(texture.LevelImage(3).size(), cv::Size(1, 1));
  const cv::Vec3b t = texture.LevelImage(1).at<cv::Vec3b>(0, 1);
  EXPECT_EQ(t[0], (0 + 0 + 40 + 40 + 2) / 4);
  EXPECT_EQ(t[1], (60 + 90 + 60 + 90 + 2) / 4);
  EXPECT_EQ(cv::norm(texture.LevelImage(0), image, cv::NORM_INF), 0.0);
}

TEST(MipTexture, SamplesInterpolateAndFilterAnisotropically) {
  // Stripes of period 2 texels (0 / 200): vertical ones (varying along a)
  // and horizontal ones (varying along b).
  cv::Mat vertical(64, 64, CV_8UC3), horizontal(64, 64, CV_8UC3);
  for (int i = 0; i < 64; ++i) {
    vertical.col(i).setTo(cv::Scalar::all(i % 2 ? 200 : 0));
    horizontal.row(i).setTo(cv::Scalar::all(i % 2 ? 200 : 0));
  }
  const MipTexture v_texture(vertical, 0.01), h_texture(horizontal, 0.01);
  // A one-texel footprint at a texel centre sees the texel itself.
  EXPECT_NEAR(v_texture.Sample(0.325f, 0.325f, 0.01f, 0, 0, 0.01f)[0], 0.0, 1.0);
  EXPECT_NEAR(v_texture.Sample(0.335f, 0.325f, 0.01f, 0, 0, 0.01f)[0], 200.0, 1.0);
  // Half-way between two texel centres at the finest level: their mean.
  EXPECT_NEAR(v_texture.SampleTrilinear(33.0f, 32.5f, 0.0f)[0], 100.0, 1e-3);
  // A footprint 8 texels long along a and one texel wide along b (a surface
  // seen at a grazing angle): the stripes across it average out wherever it
  // falls, while the stripes along it stay sharp, as they should.
  for (float a : {0.3f, 0.3025f, 0.305f, 0.3075f}) {
    EXPECT_NEAR(v_texture.Sample(a, 0.325f, 0.08f, 0, 0, 0.01f)[1], 100.0, 1.0) << a;
    EXPECT_NEAR(h_texture.Sample(a, 0.325f, 0.08f, 0, 0, 0.01f)[1], 0.0, 1.0) << a;
    EXPECT_NEAR(h_texture.Sample(a, 0.335f, 0.08f, 0, 0, 0.01f)[1], 200.0, 1.0) << a;
  }
  // An isotropic footprint of 8 texels blurs both.
  EXPECT_NEAR(h_texture.Sample(0.3f, 0.335f, 0.08f, 0, 0, 0.08f)[1], 100.0, 30.0);
  // Far beyond the texture: clamped to the edge.
  EXPECT_NEAR(v_texture.Sample(5.0f, 0.3f, 0.01f, 0, 0, 0.01f)[2], 200.0, 1e-3);
}

}  // namespace
}  // namespace rrslam::synth
