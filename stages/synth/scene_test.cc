#include "stages/synth/scene.h"

#include <gtest/gtest.h>

#include <cmath>
#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>
#include <set>

#include "stages/synth/camera_path.h"
#include "stages/synth/random.h"
#include "stages/synth/renderer.h"
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

bool SameBox(const Box& a, const Box& b) {
  return a.name == b.name && a.centre_world == b.centre_world && a.size == b.size &&
         a.yaw == b.yaw && a.inside == b.inside && a.materials == b.materials &&
         a.hidden_faces == b.hidden_faces;
}

// Whether surface `s` is a face of `box` (names are "<box>.<face>").
bool IsFaceOf(const Surface& s, const Box& box) {
  return s.name.size() == box.name.size() + 3 && s.name.rfind(box.name + ".", 0) == 0;
}

TEST(SceneChange, NoneIsTheStandardRoom) {
  const std::vector<Box> standard = StandardRoomBoxes(),
                         changed = ChangedRoomBoxes(SceneChange::kNone);
  ASSERT_EQ(changed.size(), standard.size());
  for (size_t i = 0; i < standard.size(); ++i) EXPECT_TRUE(SameBox(changed[i], standard[i])) << i;
  const SceneChangeInfo info = DescribeSceneChange(SceneChange::kNone);
  EXPECT_EQ(info.change, SceneChange::kNone);
  EXPECT_TRUE(info.moved.empty());
  EXPECT_TRUE(info.added.empty());
  EXPECT_TRUE(info.ChangedRegions().empty());
}

TEST(SceneChange, MovedBoxMovesOneBoxAndAddsOneInFreeSpace) {
  const std::vector<Box> standard = StandardRoomBoxes();
  const std::vector<Box> changed = ChangedRoomBoxes(SceneChange::kMovedBox);
  const SceneChangeInfo info = DescribeSceneChange(SceneChange::kMovedBox);
  ASSERT_EQ(info.moved.size(), 1u);
  ASSERT_EQ(info.added.size(), 1u);
  const SceneChangeInfo::Move& move = info.moved[0];
  const SceneChangeInfo::Addition& add = info.added[0];

  // One box appended; exactly one standard box differs, and only in its centre.
  ASSERT_EQ(changed.size(), standard.size() + 1);
  int differing = 0;
  for (size_t i = 0; i < standard.size(); ++i) {
    if (SameBox(changed[i], standard[i])) continue;
    ++differing;
    EXPECT_EQ(static_cast<int>(i), move.index);
    Box back = changed[i];
    back.centre_world = standard[i].centre_world;
    EXPECT_TRUE(SameBox(back, standard[i])) << "only the centre changes";
  }
  EXPECT_EQ(differing, 1);
  EXPECT_TRUE(SameBox(move.from, standard.at(move.index)));
  EXPECT_TRUE(SameBox(move.to, changed.at(move.index)));
  EXPECT_EQ(move.from.name, "screen");
  EXPECT_GE((move.to.centre_world - move.from.centre_world).norm(), 0.5);
  EXPECT_EQ(add.index, static_cast<int>(standard.size()));
  EXPECT_TRUE(SameBox(add.box, changed.back()));
  for (const Box& box : standard) EXPECT_NE(box.name, add.box.name);

  // Inside the room, clear of every other box, out of the cameras' free middle.
  const Eigen::AlignedBox3d room(Eigen::Vector3d(-3, -2.5, 0), Eigen::Vector3d(3, 2.5, 3));
  for (const Box* box : {&move.to, &add.box}) {
    const Eigen::AlignedBox3d bounds = BoxBounds(*box);
    EXPECT_TRUE(room.contains(bounds)) << box->name;
    EXPECT_NEAR(bounds.min().z(), 0.0, 1e-12) << box->name << " stands on the floor";
    for (size_t i = 1; i < changed.size(); ++i) {  // 0 is the room.
      if (changed[i].name == box->name) continue;
      EXPECT_GE(bounds.exteriorDistance(BoxBounds(changed[i])), 0.15)
          << box->name << " vs " << changed[i].name;
    }
    const Eigen::Vector2d nearest =
        Eigen::Vector2d::Zero().cwiseMax(bounds.min().head<2>()).cwiseMin(bounds.max().head<2>());
    EXPECT_GT(nearest.norm(), kStandardRoomFreeRadius + 0.3) << box->name;
  }
  // The bounds of BoxBounds hold the box's corners.
  const Eigen::AlignedBox3d crate = BoxBounds(add.box);
  const Eigen::Matrix3d R =
      Eigen::AngleAxisd(add.box.yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  for (int k = 0; k < 8; ++k) {
    const Eigen::Vector3d corner(k & 1 ? 0.5 : -0.5, k & 2 ? 0.5 : -0.5, k & 4 ? 0.5 : -0.5);
    const Eigen::Vector3d p = add.box.centre_world + R * corner.cwiseProduct(add.box.size);
    EXPECT_TRUE(crate.exteriorDistance(p) < 1e-12) << k;
  }

  // The changed regions: old and new place of the moved box, then the added box.
  const std::vector<Eigen::AlignedBox3d> regions = info.ChangedRegions();
  ASSERT_EQ(regions.size(), 3u);
  EXPECT_TRUE(regions[0].isApprox(BoxBounds(move.from)));
  EXPECT_TRUE(regions[1].isApprox(BoxBounds(move.to)));
  EXPECT_TRUE(regions[2].isApprox(BoxBounds(add.box)));
  EXPECT_FALSE(regions[0].intersects(regions[1]));
}

TEST(SceneChange, UnchangedSurfacesKeepTheirIdsAndTextures) {
  SceneOptions options;
  options.texel_size = 0.02;
  options.seed = 5;
  const Scene standard = Scene::StandardRoom(options);
  const Scene changed(ChangedRoomBoxes(SceneChange::kMovedBox), options);
  const SceneChangeInfo info = DescribeSceneChange(SceneChange::kMovedBox);
  const Eigen::Vector3d shift = info.moved[0].to.centre_world - info.moved[0].from.centre_world;
  ASSERT_GT(changed.surfaces().size(), standard.surfaces().size());
  for (const Surface& s : standard.surfaces()) {
    const Surface& c = changed.surface(s.id);
    ASSERT_EQ(c.name, s.name);
    // The moved box is the same object: same texture, carried along.
    const Eigen::Vector3d expected_origin =
        IsFaceOf(s, info.moved[0].from) ? Eigen::Vector3d(s.origin_world + shift) : s.origin_world;
    EXPECT_TRUE(c.origin_world.isApprox(expected_origin, 1e-12)) << s.name;
    EXPECT_EQ(c.normal_world, s.normal_world) << s.name;
    EXPECT_EQ(cv::norm(standard.texture(s.id).LevelImage(0), changed.texture(s.id).LevelImage(0),
                       cv::NORM_INF),
              0.0)
        << s.name;
  }
  for (size_t i = standard.surfaces().size(); i < changed.surfaces().size(); ++i) {
    EXPECT_TRUE(IsFaceOf(changed.surface(i), info.added[0].box)) << changed.surface(i).name;
  }
}

TEST(SceneChange, ChangedPlacesAreSeenByTheLoop) {
  // The default loop (300 frames at 30 fps, looking east) and a full-turn lap
  // (600 frames) see the moved box at its old and new place and the added box.
  SceneOptions options;
  options.texel_size = 0.05;
  const Scene standard = Scene::StandardRoom(options);
  const Scene changed(ChangedRoomBoxes(SceneChange::kMovedBox), options);
  const SceneChangeInfo info = DescribeSceneChange(SceneChange::kMovedBox);
  const PinholeCamera camera(131.25, 131.25, 79.5, 59.5, 160, 120);
  const Renderer render_standard(standard, camera), render_changed(changed, camera);
  for (int frames : {300, 600}) {
    const Trajectory path = MakeTrajectory(TrajectoryKind::kLoop, frames, 30.0);
    int old_place = 0, new_place = 0, added = 0, sampled = 0;
    for (int i = 0; i < frames; i += 10, ++sampled) {
      auto count = [](const Scene& scene, const RenderedFrame& frame, const Box& box) {
        int n = 0;
        for (auto it = frame.surface_id.begin<int>(); it != frame.surface_id.end<int>(); ++it) {
          if (*it >= 0 && IsFaceOf(scene.surface(*it), box)) ++n;
        }
        return n;
      };
      const RenderedFrame a = render_standard.Render(path[i].T_world_cam);
      const RenderedFrame b = render_changed.Render(path[i].T_world_cam);
      // At least 100 pixels of the 160 x 120 (0.5%).
      if (count(standard, a, info.moved[0].from) >= 100) ++old_place;
      if (count(changed, b, info.moved[0].to) >= 100) ++new_place;
      if (count(changed, b, info.added[0].box) >= 100) ++added;
    }
    // The default loop looks east, at the changes, most of the time (in 16
    // to 23 of the 30 samples); the full turn, a sixth of the time (7 to 10
    // of 60).
    const int min_frames = frames == 300 ? sampled / 3 : 4;
    EXPECT_GE(old_place, min_frames) << frames;
    EXPECT_GE(new_place, min_frames) << frames;
    EXPECT_GE(added, min_frames) << frames;
  }
}
}  // namespace
}  // namespace rrslam::synth
