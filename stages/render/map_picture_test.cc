#include "stages/render/map_picture.h"

#include <gtest/gtest.h>

#include <cmath>

#include "common/chart.h"
#include "common/errors.h"
#include "stages/render/render_test_util.h"

namespace rrslam {
namespace {

const Eigen::Quaterniond kLookAlongX(Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitY()));

// Keyframe 0 at the origin looking along +z; keyframe 1 at (2, 0, 0) looking
// along +x (its optical axis z_cam maps to world +x); points in front of both.
MapScene KnownScene() {
  const std::vector<Rigid3d> poses = {Rigid3d::Identity(),
                                      Rigid3d(kLookAlongX, Eigen::Vector3d(2, 0, 0))};
  std::vector<Eigen::Vector3d> points;
  for (int i = 0; i < 40; ++i) {
    points.emplace_back(-0.5 + 0.05 * i, 0.3 * std::sin(i), 3.0);  // A wall 3 m ahead.
    points.emplace_back(4.0, 0.2 * std::cos(i), -0.5 + 0.05 * i);  // A wall keyframe 1 sees.
  }
  return MakeMapScene(testing::MakeKnownMap(poses, points), "known.rrm");
}

int CountColour(const cv::Mat& image, const cv::Rect& box, const cv::Scalar& bgr) {
  int count = 0;
  const cv::Rect clipped = box & cv::Rect(0, 0, image.cols, image.rows);
  for (int y = clipped.y; y < clipped.br().y; ++y) {
    for (int x = clipped.x; x < clipped.br().x; ++x) {
      const cv::Vec3b p = image.at<cv::Vec3b>(y, x);
      if (std::abs(p[0] - bgr[0]) + std::abs(p[1] - bgr[1]) + std::abs(p[2] - bgr[2]) < 40) ++count;
    }
  }
  return count;
}

bool IsBackground(const cv::Vec3b& p) { return p[0] == 255 && p[1] == 255 && p[2] == 255; }

TEST(GroundFrame, RightForwardUpAreRightHanded) {
  const GroundFrame level = MakeGroundFrame("-y");
  EXPECT_EQ(level.right, Eigen::Vector3d::UnitX());
  EXPECT_EQ(level.forward, Eigen::Vector3d::UnitZ());
  EXPECT_EQ(level.up_name, "-y");
  const GroundFrame z_up = MakeGroundFrame("z");
  EXPECT_EQ(z_up.forward, Eigen::Vector3d::UnitX());
  EXPECT_EQ(z_up.right, -Eigen::Vector3d::UnitY());
  EXPECT_EQ(z_up.right_name, "-y");
  for (const char* up : {"x", "-x", "y", "-y", "z", "-z"}) {
    const GroundFrame f = MakeGroundFrame(up);
    EXPECT_NEAR(f.right.cross(f.forward).dot(f.up), 1.0, 1e-12) << up;
  }
  EXPECT_THROW(MakeGroundFrame("w"), UsageError);
  EXPECT_THROW(MakeGroundFrame("--y"), UsageError);
}

TEST(MapPicture, TopViewPutsAPointOnItsPixelWithXRightAndZUp) {
  MapPictureOptions options;
  options.frusta = options.trajectory = options.spanning_tree = false;
  options.point_radius_px = 3;
  const MapScene scene = KnownScene();
  const MapPicture picture = RenderMapPicture(scene, MapViewKind::kTop, options);
  ASSERT_EQ(picture.image.size(), cv::Size(1200, 900));
  const MapViewProjection& projection = picture.projection;
  // x to the right, z (forward) up the image.
  const cv::Point2d a = *projection.Project({0, 0, 3});
  const cv::Point2d b = *projection.Project({1, 0, 3});
  const cv::Point2d c = *projection.Project({0, 0, 4});
  EXPECT_GT(b.x, a.x + 10);
  EXPECT_NEAR(b.y, a.y, 1e-9);
  EXPECT_LT(c.y, a.y - 10);
  EXPECT_NEAR(c.x, a.x, 1e-9);
  EXPECT_NEAR(b.x - a.x, a.y - c.y, 1e-9);  // Equal scale.
  // Every point is drawn where the projection says.
  for (const ScenePoint& point : scene.points) {
    const cv::Point2d p = *projection.Project(point.position);
    const cv::Vec3b pixel = picture.image.at<cv::Vec3b>(static_cast<int>(std::lround(p.y)),
                                                        static_cast<int>(std::lround(p.x)));
    EXPECT_FALSE(IsBackground(pixel)) << point.position.transpose();
  }
  // A place with no point stays background (the middle of the empty
  // region between the two walls, away from grid lines).
  bool all_background = true;
  const cv::Point2d empty = *projection.Project({3.0, 0, 1.5});
  for (int dy = -3; dy <= 3; ++dy)
    for (int dx = -3; dx <= 3; ++dx) {
      const cv::Vec3b p = picture.image.at<cv::Vec3b>(static_cast<int>(empty.y) + dy,
                                                      static_cast<int>(empty.x) + dx);
      all_background &= p[0] > 200 && p[1] > 200 && p[2] > 200;
    }
  EXPECT_TRUE(all_background);
  // Axes are labelled with world axes and units, a scale bar is drawn.
  EXPECT_NE(std::find(picture.labels.begin(), picture.labels.end(), "x [m]"), picture.labels.end());
  EXPECT_NE(std::find(picture.labels.begin(), picture.labels.end(), "z [m]"), picture.labels.end());
  EXPECT_TRUE(std::any_of(picture.labels.begin(), picture.labels.end(),
                          [](const std::string& s) { return s.rfind("scale ", 0) == 0; }));
  // The x label is drawn under the plot area, around its centre.
  const chart::ChartLayout layout = chart::MakeLayout(picture.image.size(), true);
  const cv::Rect& area = layout.area;
  int text_pixels = 0;  // Below the tick labels, above the footer row.
  for (int y = area.br().y + layout.tick + 2 * layout.text_height;
       y < layout.footer_y - layout.text_height; ++y)
    for (int x = area.x + area.width / 2 - 40; x < area.x + area.width / 2 + 40; ++x) {
      const cv::Vec3b p = picture.image.at<cv::Vec3b>(y, x);
      if (p[0] < 120 && p[1] < 120 && p[2] < 120) ++text_pixels;
    }
  EXPECT_GT(text_pixels, 20);
}

TEST(MapPicture, FrustaPointTheWayTheCamerasLook) {
  MapPictureOptions options;
  options.trajectory = options.spanning_tree = false;
  options.frustum_size = 0.5;
  options.point_radius_px = 1;
  const MapScene scene = KnownScene();
  const MapPicture picture = RenderMapPicture(scene, MapViewKind::kTop, options);
  const cv::Scalar frustum(190, 100, 20);
  const double ppm = picture.projection.pixels_per_metre;
  const int reach = static_cast<int>(0.45 * ppm);
  // Keyframe 0 looks along +z: its frustum is above its centre in the top view.
  const cv::Point2d c0 = *picture.projection.Project({0, 0, 0});
  const int above = CountColour(
      picture.image, cv::Rect(c0.x - reach, c0.y - reach, 2 * reach, reach - 2), frustum);
  const int below =
      CountColour(picture.image, cv::Rect(c0.x - reach, c0.y + 3, 2 * reach, reach), frustum);
  EXPECT_GT(above, 20);
  EXPECT_EQ(below, 0);
  // Keyframe 1 looks along +x: its frustum is to the right of its centre.
  const cv::Point2d c1 = *picture.projection.Project({2, 0, 0});
  const int right =
      CountColour(picture.image, cv::Rect(c1.x + 3, c1.y - reach, reach, 2 * reach), frustum);
  const int left = CountColour(picture.image,
                               cv::Rect(c1.x - reach, c1.y - reach, reach - 3, 2 * reach), frustum);
  EXPECT_GT(right, 20);
  EXPECT_EQ(left, 0);
}

TEST(MapPicture, PerspectiveUsesOrbSlam2Viewpoint) {
  MapPictureOptions options;
  options.viewpoint = Viewpoint{0, -0.7, -1.8, 500};
  const MapScene scene = KnownScene();
  const MapPicture picture = RenderMapPicture(scene, MapViewKind::kPerspective, options);
  const MapViewProjection& projection = picture.projection;
  // The eye looks at the origin: it lands on the principal point, which is
  // Pangolin's (512, 389) of 1024 x 768 scaled to the view.
  double depth = 0;
  const cv::Point2d origin = *projection.Project({0, 0, 0}, &depth);
  EXPECT_NEAR(origin.x, projection.cx, 1e-6);
  EXPECT_NEAR(origin.y, projection.cy, 1e-6);
  EXPECT_NEAR(depth, std::sqrt(0.7 * 0.7 + 1.8 * 1.8), 1e-9);
  EXPECT_NEAR(projection.fx, 500 * 1200 / 1024.0, 1e-9);
  // Up (-y) is up in the image; +x is to the right; behind the eye is not drawn.
  EXPECT_LT(projection.Project({0, -0.5, 0})->y, origin.y);
  EXPECT_GT(projection.Project({0.5, 0, 0})->x, origin.x);
  EXPECT_FALSE(projection.Project({0, -0.7, -3}).has_value());
  EXPECT_NE(std::find(picture.labels.begin(), picture.labels.end(), "x"), picture.labels.end());
}

TEST(MapPicture, AgeColoursTellLoadedFromAddedPoints) {
  MapScene scene = KnownScene();
  scene.has_loaded_part = true;
  for (size_t i = 0; i < scene.points.size(); ++i) scene.points[i].loaded = i % 2 == 0;
  MapPictureOptions options;
  options.colouring = PointColouring::kAge;
  options.frusta = options.trajectory = options.spanning_tree = false;
  options.point_radius_px = 3;
  const MapPicture picture = RenderMapPicture(scene, MapViewKind::kTop, options);
  for (size_t i = 0; i < scene.points.size(); ++i) {
    const cv::Point2d p = *picture.projection.Project(scene.points[i].position);
    const cv::Vec3b pixel = picture.image.at<cv::Vec3b>(static_cast<int>(std::lround(p.y)),
                                                        static_cast<int>(std::lround(p.x)));
    const cv::Vec3b expected =
        scene.points[i].loaded ? cv::Vec3b(165, 165, 165) : cv::Vec3b(0, 140, 255);
    EXPECT_EQ(pixel, expected) << i;
  }
  EXPECT_NE(std::find(picture.labels.begin(), picture.labels.end(),
                      "loaded points (" + std::to_string((scene.points.size() + 1) / 2) + ")"),
            picture.labels.end());
}

TEST(MapPicture, RefusesBadOptionsAndEmptyMaps) {
  MapPictureOptions options;
  options.width_px = 100;
  EXPECT_THROW(RenderMapPicture(KnownScene(), MapViewKind::kTop, options), UsageError);
  options = {};
  options.up = "q";
  EXPECT_THROW(RenderMapPicture(KnownScene(), MapViewKind::kTop, options), UsageError);
  MapScene empty;
  empty.source = "empty.rrm";
  EXPECT_THROW(RenderMapPicture(empty, MapViewKind::kTop, {}), DataError);
}

}  // namespace
}  // namespace rrslam
