#include "stages/render/dense/dense_model.h"

#include <gtest/gtest.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "common/camera.h"
#include "common/errors.h"
#include "common/image_io.h"
#include "common/testing.h"
#include "stages/mapstore/map_file.h"
#include "stages/mapstore/map_test_util.h"
#include "stages/render/image_file.h"
#include "stages/render/map_scene.h"
#include "stages/render/ply.h"

namespace rrslam {
namespace {

namespace fs = std::filesystem;
using testing::TempDir;

// The synthetic scene, in the world frame (metres): a plane facing the
// cameras, textured with a checkerboard of 10 cm squares in two colours, and
// a green axis-aligned cube floating in front of it.
struct Scene {
  Eigen::Vector3d plane_point{0.0, 0.0, 1.3};
  Eigen::Vector3d plane_normal = Eigen::Vector3d(0.25, -0.2, -1.0).normalized();  // To the cameras.
  Eigen::Vector3d plane_u, plane_v;  // Orthonormal basis of the plane (texture axes).
  Eigen::Vector3d box_centre{0.12, 0.06, 0.95};
  double box_half = 0.08;
  double square = 0.10;
  Eigen::Vector3d color_a{220, 60, 40};   // RGB.
  Eigen::Vector3d color_b{30, 110, 200};  // RGB.
  Eigen::Vector3d color_box{40, 180, 60};

  Scene() {
    plane_u = plane_normal.unitOrthogonal();
    plane_v = plane_normal.cross(plane_u);
  }

  // Texture coordinates of a plane point.
  Eigen::Vector2d Texture(const Eigen::Vector3d& p) const {
    const Eigen::Vector3d r = p - plane_point;
    return {r.dot(plane_u), r.dot(plane_v)};
  }
  Eigen::Vector3d PlaneColor(const Eigen::Vector3d& p) const {
    const Eigen::Vector2d t = Texture(p) / square;
    const long parity = static_cast<long>(std::floor(t.x()) + std::floor(t.y()));
    return parity % 2 == 0 ? color_a : color_b;
  }
  // Distance from a plane point to the nearest checker edge, metres.
  double EdgeDistance(const Eigen::Vector3d& p) const {
    const Eigen::Vector2d t = Texture(p) / square;
    const double fx = t.x() - std::floor(t.x()), fy = t.y() - std::floor(t.y());
    return square * std::min({fx, 1 - fx, fy, 1 - fy});
  }
  double PlaneDistance(const Eigen::Vector3d& p) const {
    return (p - plane_point).dot(plane_normal);  // > 0 on the cameras' side.
  }
  double BoxDistance(const Eigen::Vector3d& p) const {
    const Eigen::Vector3d d = (p - box_centre).cwiseAbs() - Eigen::Vector3d::Constant(box_half);
    const double outside = d.cwiseMax(0.0).norm();
    return outside > 0 ? outside : -d.maxCoeff();
  }
  double Distance(const Eigen::Vector3d& p) const {
    return std::min(std::abs(PlaneDistance(p)), BoxDistance(p));
  }

  // The first surface along a ray from `origin` (unit `dir`): distance and RGB.
  bool Hit(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir, double* t,
           Eigen::Vector3d* rgb) const {
    double best = std::numeric_limits<double>::infinity();
    // Box (slabs).
    double t_near = -std::numeric_limits<double>::infinity();
    double t_far = std::numeric_limits<double>::infinity();
    for (int k = 0; k < 3; ++k) {
      const double lo = (box_centre[k] - box_half - origin[k]) / dir[k];
      const double hi = (box_centre[k] + box_half - origin[k]) / dir[k];
      t_near = std::max(t_near, std::min(lo, hi));
      t_far = std::min(t_far, std::max(lo, hi));
    }
    if (t_near <= t_far && t_near > 0) {
      best = t_near;
      *rgb = color_box;
    }
    const double denom = dir.dot(plane_normal);
    if (std::abs(denom) > 1e-9) {
      const double tp = (plane_point - origin).dot(plane_normal) / denom;
      if (tp > 0 && tp < best) {
        best = tp;
        *rgb = PlaneColor(origin + tp * dir);
      }
    }
    *t = best;
    return std::isfinite(best);
  }
};

constexpr int kWidth = 240, kHeight = 180;
constexpr double kFocal = 220, kCx = 119.5, kCy = 89.5;
constexpr double kDepthFactor = 5000;

PinholeCamera TestCamera(const Distortion& distortion = {}) {
  return PinholeCamera(kFocal, kFocal, kCx, kCy, kWidth, kHeight, distortion);
}

// Three keyframe poses (camera-to-world) looking at the scene from slightly
// different places.
std::vector<Rigid3d> TestPoses() {
  std::vector<Rigid3d> poses;
  const double yaw[3] = {0.08, 0.0, -0.09};
  const double pitch[3] = {0.02, -0.05, 0.04};
  const Eigen::Vector3d centres[3] = {{-0.18, 0.02, 0.0}, {0.0, -0.06, -0.05}, {0.17, 0.04, 0.02}};
  for (int i = 0; i < 3; ++i) {
    const Eigen::Quaterniond q = Eigen::AngleAxisd(yaw[i], Eigen::Vector3d::UnitY()) *
                                 Eigen::AngleAxisd(pitch[i], Eigen::Vector3d::UnitX());
    poses.emplace_back(q, centres[i]);
  }
  return poses;
}

// Renders depth (CV_32FC1 metres along z) and colour (BGR) of the scene at
// `T_world_cam`; with distortion, pixels are real (distorted) pixels.
void RenderView(const Scene& scene, const PinholeCamera& camera, const Rigid3d& T_world_cam,
                cv::Mat* depth, cv::Mat* color) {
  *depth = cv::Mat::zeros(kHeight, kWidth, CV_32FC1);
  *color = cv::Mat::zeros(kHeight, kWidth, CV_8UC3);
  const Eigen::Matrix3d R = T_world_cam.RotationMatrix();
  for (int v = 0; v < kHeight; ++v) {
    for (int u = 0; u < kWidth; ++u) {
      const Eigen::Vector2d ideal = camera.UndistortPixel(Eigen::Vector2d(u, v));
      const Eigen::Vector3d ray_cam((ideal.x() - kCx) / kFocal, (ideal.y() - kCy) / kFocal, 1.0);
      double t = 0;
      Eigen::Vector3d rgb = Eigen::Vector3d::Zero();
      if (!scene.Hit(T_world_cam.translation, (R * ray_cam).normalized(), &t, &rgb)) continue;
      depth->at<float>(v, u) = static_cast<float>(t / ray_cam.norm());  // z in the camera.
      color->at<cv::Vec3b>(v, u) = cv::Vec3b(
          static_cast<uint8_t>(rgb[2]), static_cast<uint8_t>(rgb[1]), static_cast<uint8_t>(rgb[0]));
    }
  }
}

std::string Stamp(double t) {
  char buffer[32];
  std::snprintf(buffer, sizeof(buffer), "%.6f", t);
  return buffer;
}

// Writes a TUM-layout sequence of 5 frames (t = 100.0, 100.1, ...; keyframes
// are frames 0, 2 and 4) and the map of its 3 keyframes.
void WriteSequenceAndMap(const Scene& scene, const fs::path& sequence, const fs::path& map_path,
                         const Distortion& distortion = {}) {
  const PinholeCamera camera = TestCamera(distortion);
  const std::vector<Rigid3d> poses = TestPoses();
  fs::create_directories(sequence / "rgb");
  fs::create_directories(sequence / "depth");
  std::string rgb_list = "# color images\n", depth_list = "# depth maps\n";
  for (int i = 0; i < 5; ++i) {
    const std::string t = Stamp(100.0 + 0.1 * i);
    // Frames between keyframes see from the midpoint (never fused).
    const Rigid3d pose =
        i % 2 == 0 ? poses[i / 2] : Interpolate(poses[i / 2], poses[i / 2 + 1], 0.5);
    cv::Mat depth, color, depth16;
    RenderView(scene, camera, pose, &depth, &color);
    depth.convertTo(depth16, CV_16UC1, kDepthFactor);
    WritePng(sequence / "rgb" / (t + ".png"), color);
    WritePng(sequence / "depth" / (t + ".png"), depth16);
    rgb_list += t + " rgb/" + t + ".png\n";
    depth_list += t + " depth/" + t + ".png\n";
  }
  testing::WriteTextFile(sequence / "rgb.txt", rgb_list);
  testing::WriteTextFile(sequence / "depth.txt", depth_list);

  testing::TestMapOptions map_options;
  map_options.keyframes = 3;
  map_options.keypoints = 12;
  map_options.map_points = 10;
  map_options.bow_words = 5;
  MapData map = testing::MakeTestMap(7, map_options);
  MapCamera& c = map.camera;
  c.fx = c.fy = kFocal;
  c.cx = kCx;
  c.cy = kCy;
  c.k1 = distortion.k1;
  c.k2 = distortion.k2;
  c.p1 = distortion.p1;
  c.p2 = distortion.p2;
  c.k3 = distortion.k3;
  c.width = kWidth;
  c.height = kHeight;
  c.depth_map_factor = kDepthFactor;
  for (int k = 0; k < 3; ++k) {
    KeyFrameRecord& kf = map.keyframes[k];
    kf.timestamp = 100.0 + 0.2 * k;
    const Rigid3d T_cam_world = poses[k].Inverse();
    const Eigen::Quaterniond& q = T_cam_world.rotation;
    const Eigen::Vector3d& t = T_cam_world.translation;
    kf.T_cam_world = {q.w(), q.x(), q.y(), q.z(), t.x(), t.y(), t.z()};
  }
  WriteMapFile(map_path, map);
}

struct Accuracy {
  size_t points = 0;
  double within = 0;             // Fraction within 1.5 voxels of the scene.
  double mean_plane_offset = 0;  // Signed, metres, plane points away from the box.
  double color_match = 0;  // Fraction of plane points off checker edges with the texture's colour.
  double normals_facing = 0;  // Fraction of normals facing one of the cameras.
  double box_green = 0;       // Fraction of the box's front face points that are green.
};

Accuracy Measure(const Scene& scene, const PlyCloud& cloud, double voxel) {
  Accuracy a;
  a.points = cloud.positions.size();
  const std::vector<Rigid3d> poses = TestPoses();
  size_t within = 0, plane = 0, colored = 0, matched = 0, facing = 0, box = 0, green = 0;
  double offset = 0;
  for (size_t i = 0; i < cloud.positions.size(); ++i) {
    const Eigen::Vector3d p = cloud.positions[i].cast<double>();
    const Eigen::Vector3d rgb(cloud.colors[i][0], cloud.colors[i][1], cloud.colors[i][2]);
    if (scene.Distance(p) <= 1.5 * voxel) ++within;
    for (const Rigid3d& pose : poses) {
      if (cloud.normals[i].cast<double>().dot(pose.translation - p) > 0) {
        ++facing;
        break;
      }
    }
    if (scene.BoxDistance(p) > 0.05 && std::abs(scene.PlaneDistance(p)) < 3 * voxel) {
      ++plane;
      offset += scene.PlaneDistance(p);
      if (scene.EdgeDistance(p) > 0.02) {
        ++colored;
        if ((rgb - scene.PlaneColor(p)).cwiseAbs().maxCoeff() <= 40) ++matched;
      }
    }
    // The box's front face, off its edges (its sides are seen at grazing
    // angles, where a voxel's colour is the background seen past it).
    const Eigen::Vector3d r = p - scene.box_centre;
    if (std::abs(r.z() + scene.box_half) < 1.5 * voxel && std::abs(r.x()) < scene.box_half - 0.02 &&
        std::abs(r.y()) < scene.box_half - 0.02) {
      ++box;
      if ((rgb - scene.color_box).cwiseAbs().maxCoeff() <= 40) ++green;
    }
  }
  a.within = static_cast<double>(within) / std::max<size_t>(1, a.points);
  a.normals_facing = static_cast<double>(facing) / std::max<size_t>(1, a.points);
  a.mean_plane_offset = offset / std::max<size_t>(1, plane);
  a.color_match = static_cast<double>(matched) / std::max<size_t>(1, colored);
  a.box_green = static_cast<double>(green) / std::max<size_t>(1, box);
  EXPECT_GT(plane, a.points / 2);
  EXPECT_GT(box, 100u);
  return a;
}

DenseOptions TestOptions(const TempDir& dir) {
  DenseOptions o;
  o.map = dir / "map.rrm";
  o.sequence = dir / "seq";
  o.out = dir / "model.ply";
  o.image_width = 320;
  return o;
}

void ExpectAccurate(const Accuracy& a, double voxel) {
  EXPECT_GT(a.points, 5000u);
  EXPECT_GE(a.within, 0.99) << "points within 1.5 voxels of the scene";
  // Half a voxel along each axis would show as ~0.4 voxels here.
  EXPECT_LT(std::abs(a.mean_plane_offset), 0.15 * voxel) << "mean signed offset from the plane";
  EXPECT_GE(a.color_match, 0.95);
  EXPECT_GE(a.box_green, 0.95);
  EXPECT_GE(a.normals_facing, 0.99);
}

TEST(DenseOptions, Checks) {
  std::string why;
  DenseOptions o;
  EXPECT_FALSE(o.Check(&why));
  EXPECT_NE(why.find("--map"), std::string::npos) << why;
  o.map = "m.rrm";
  o.sequence = "seq";
  o.out = "model.ply";
  EXPECT_TRUE(o.Check(&why)) << why;
  EXPECT_EQ(o.ImagePath(), fs::path("model.png"));
  EXPECT_DOUBLE_EQ(o.EffectiveTruncation(), 0.04);
  const nlohmann::ordered_json j = o.ToJson();
  EXPECT_EQ(j["image"], "model.png");
  EXPECT_EQ(j["truncation"], 0.04);

  auto expect_fails = [&](DenseOptions bad, const std::string& flag) {
    std::string reason;
    EXPECT_FALSE(bad.Check(&reason)) << flag;
    EXPECT_NE(reason.find(flag), std::string::npos) << reason;
  };
  DenseOptions bad = o;
  bad.sequence.clear();
  expect_fails(bad, "--sequence");
  bad = o;
  bad.out.clear();
  expect_fails(bad, "--out");
  bad = o;
  bad.out = "model.txt";
  expect_fails(bad, "--out");
  bad = o;
  bad.image = "model.jpg";
  expect_fails(bad, "--image");
  bad = o;
  bad.image = "x/../model.ply";
  expect_fails(bad, "--image");
  bad = o;
  bad.out = "m.ply";
  bad.map = "m.ply";
  expect_fails(bad, "map");
  bad = o;
  bad.voxel = 0;
  expect_fails(bad, "--voxel");
  bad = o;
  bad.voxel = std::nan("");
  expect_fails(bad, "--voxel");
  bad = o;
  bad.truncation = -1;
  expect_fails(bad, "--truncation");
  bad = o;
  bad.truncation = 0.02;  // 2 voxels.
  expect_fails(bad, "--truncation");
  bad = o;
  bad.max_depth = 0;
  expect_fails(bad, "--max-depth");
  bad = o;
  bad.max_volume_gb = 16;
  expect_fails(bad, "--max-volume-gb");
  bad = o;
  bad.max_volume_gb = 0;
  expect_fails(bad, "--max-volume-gb");
  bad = o;
  bad.image_width = 10;
  expect_fails(bad, "--image-width");
  bad = o;
  bad.threads = 0;
  expect_fails(bad, "--threads");
}

TEST(DenseOptions, BindsFlags) {
  CLI::App app;
  DenseOptions o;
  BindDenseOptions(&app, &o);
  app.parse(
      "--map m.rrm --sequence s --out o.ply --voxel 0.02 --ascii --threads 1 --max-depth 0.5");
  EXPECT_EQ(o.map, fs::path("m.rrm"));
  EXPECT_EQ(o.sequence, fs::path("s"));
  EXPECT_EQ(o.out, fs::path("o.ply"));
  EXPECT_DOUBLE_EQ(o.voxel, 0.02);
  EXPECT_DOUBLE_EQ(o.max_depth, 0.5);
  EXPECT_FALSE(o.binary);
  EXPECT_EQ(o.threads, 1);
  DenseOptions defaults;
  CLI::App app2;
  BindDenseOptions(&app2, &defaults);
  app2.parse("--map m --sequence s --out o.ply");
  EXPECT_TRUE(defaults.binary);
  EXPECT_DOUBLE_EQ(defaults.voxel, 0.01);
}

Rigid3d LookingAlong(const Eigen::Vector3d& forward, const Eigen::Vector3d& up) {
  Eigen::Matrix3d R;
  R.col(2) = forward.normalized();
  R.col(1) = -(up - up.dot(R.col(2)) * R.col(2)).normalized();
  R.col(0) = R.col(1).cross(R.col(2));
  return Rigid3d(Eigen::Quaterniond(R), Eigen::Vector3d::Zero());
}

void ExpectRotation(const Eigen::Matrix3d& R) {
  EXPECT_TRUE(R.isUnitary(1e-9));
  EXPECT_NEAR(R.determinant(), 1.0, 1e-9);
}

TEST(DenseVolumeAxes, UpWhenEveryViewLooksLevelOrDown) {
  const Eigen::Vector3d up(0, -1, 0);  // The cameras' -y.
  std::vector<Rigid3d> poses;
  for (int i = 0; i < 12; ++i) {  // All around, 5 and 25 degrees down in turn.
    const double yaw = i * M_PI / 6, down = (i % 2 == 0 ? 5 : 25) * M_PI / 180;
    poses.push_back(LookingAlong(Eigen::Vector3d(std::sin(yaw) * std::cos(down), std::sin(down),
                                                 std::cos(yaw) * std::cos(down)),
                                 up));
  }
  size_t against = 99;
  const Eigen::Matrix3d R = ChooseDenseVolumeAxes(poses, &against);
  ExpectRotation(R);
  EXPECT_EQ(against, 0u);
  EXPECT_GT(R.col(2).dot(up), 1 - 1e-9);
}

TEST(DenseVolumeAxes, AgainstEveryOpticalAxisWhenOneDirectionCan) {
  // Views within 60 degrees of +z, some looking up: up does not serve them all.
  std::vector<Rigid3d> poses;
  for (int i = 0; i < 10; ++i) {
    const double a = i * 2 * M_PI / 10;
    poses.push_back(LookingAlong(Eigen::Vector3d(1.5 * std::cos(a), 1.5 * std::sin(a), 1.0),
                                 Eigen::Vector3d(0, -1, 0)));
  }
  size_t against = 99;
  const Eigen::Matrix3d R = ChooseDenseVolumeAxes(poses, &against);
  ExpectRotation(R);
  EXPECT_EQ(against, 0u);
  for (const Rigid3d& pose : poses) EXPECT_LE(pose.RotationMatrix().col(2).dot(R.col(2)), 0.0);
  // Views along +z and -z: perpendicular serves both.
  poses = {LookingAlong({0, 0, 1}, {0, -1, 0}), LookingAlong({0, 0, -1}, {0, -1, 0})};
  ChooseDenseVolumeAxes(poses, &against);
  EXPECT_EQ(against, 0u);
}

TEST(DenseVolumeAxes, CountsViewsNoDirectionServes) {
  std::vector<Rigid3d> poses;
  for (const Eigen::Vector3d& d :
       {Eigen::Vector3d(1, 0, 0), Eigen::Vector3d(-1, 0, 0), Eigen::Vector3d(0, 1, 0),
        Eigen::Vector3d(0, -1, 0), Eigen::Vector3d(0, 0, 1), Eigen::Vector3d(0, 0, -1)}) {
    poses.push_back(LookingAlong(d, d.unitOrthogonal()));
  }
  size_t against = 0;
  ExpectRotation(ChooseDenseVolumeAxes(poses, &against));
  EXPECT_GE(against, 1u);
  EXPECT_LE(against, 3u);
}

// The core without files: views rendered in memory.
TEST(DenseModel, PlaneAndBoxLandWhereTheyAre) {
  const Scene scene;
  const PinholeCamera camera = TestCamera();
  const std::vector<Rigid3d> poses = TestPoses();
  DenseOptions options;
  options.image_width = 320;
  const DenseImageLoader load = [&](size_t i, bool with_color) {
    KeyFrameView images;
    cv::Mat color;
    RenderView(scene, camera, poses.at(i), &images.depth, &color);
    if (with_color) images.color = color;
    return images;
  };
  const DenseModel model =
      BuildDenseModel(options, {kFocal, kFocal, kCx, kCy, kWidth, kHeight}, poses, load);
  const DenseResult& r = model.result;
  EXPECT_EQ(r.keyframes_fused, 3u);
  EXPECT_EQ(r.points, model.cloud.positions.size());
  ASSERT_EQ(model.cloud.normals.size(), r.points);
  ASSERT_EQ(model.cloud.colors.size(), r.points);
  // Every view looks against the volume's z axis; the volume holds the
  // depth points (volume frame) with a margin.
  EXPECT_EQ(r.views_against_axis, 0u);
  EXPECT_TRUE(r.R_world_volume.isUnitary(1e-9));
  EXPECT_NEAR(r.R_world_volume.determinant(), 1.0, 1e-9);
  for (const Rigid3d& pose : poses) {
    EXPECT_LE(pose.RotationMatrix().col(2).dot(r.R_world_volume.col(2)), 0.0);
  }
  const Eigen::Vector3d corner = r.R_world_volume.transpose() * r.volume_origin;
  for (int k = 0; k < 3; ++k) {
    EXPECT_LT(corner[k], r.depth_bounds.min()[k] - r.truncation);
    EXPECT_GT(corner[k] + (r.resolution[k] - 1) * r.voxel, r.depth_bounds.max()[k] + r.truncation);
  }
  EXPECT_EQ(r.volume_bytes, static_cast<size_t>(8) * r.resolution.prod());
  ExpectAccurate(Measure(scene, model.cloud, options.voxel), options.voxel);
  // The rendering shows the model: most pixels are not background, and the
  // green box is in the picture.
  ASSERT_EQ(model.rendering.type(), CV_8UC3);
  EXPECT_EQ(model.rendering.cols, 320);
  EXPECT_EQ(model.rendering.rows, 240);
  size_t greenish = 0, bright = 0;
  for (int v = 0; v < model.rendering.rows; ++v) {
    for (int u = 0; u < model.rendering.cols; ++u) {
      const cv::Vec3b bgr = model.rendering.at<cv::Vec3b>(v, u);
      if (bgr[1] > 100 && bgr[1] > bgr[0] + 40 && bgr[1] > bgr[2] + 40) ++greenish;
      if (bgr[0] + bgr[1] + bgr[2] > 200) ++bright;
    }
  }
  EXPECT_GT(greenish, 500u);
  EXPECT_GT(bright, static_cast<size_t>(0.5 * 320 * 240));
}

// Depth beyond --max-depth is not fused: only the box remains.
TEST(DenseModel, MaxDepthClips) {
  const Scene scene;
  const PinholeCamera camera = TestCamera();
  const std::vector<Rigid3d> poses = TestPoses();
  DenseOptions options;
  options.image_width = 64;
  options.max_depth = 1.1;
  const DenseImageLoader load = [&](size_t i, bool) {
    KeyFrameView images;
    RenderView(scene, camera, poses.at(i), &images.depth, &images.color);
    return images;
  };
  const DenseModel model =
      BuildDenseModel(options, {kFocal, kFocal, kCx, kCy, kWidth, kHeight}, poses, load);
  // Every point is within max_depth of a camera (plus the rounding of the
  // surface), and the box is there.
  const double voxel = options.voxel;
  size_t near = 0, on_box = 0;
  for (const Eigen::Vector3f& point : model.cloud.positions) {
    const Eigen::Vector3d p = point.cast<double>();
    double depth = std::numeric_limits<double>::infinity();
    for (const Rigid3d& pose : poses) depth = std::min(depth, (pose.Inverse() * p).z());
    if (depth <= options.max_depth + 1.5 * voxel) ++near;
    if (std::abs(scene.BoxDistance(p)) <= 1.5 * voxel) ++on_box;
  }
  EXPECT_EQ(near, model.cloud.positions.size());
  EXPECT_GT(on_box, 300u);
}

class DenseRun : public ::testing::Test {
 protected:
  TempDir dir_;
  Scene scene_;
};

TEST_F(DenseRun, WritesPlyAndPicture) {
  WriteSequenceAndMap(scene_, dir_ / "seq", dir_ / "map.rrm");
  DenseOptions options = TestOptions(dir_);
  const DenseResult result = RunDense(options);
  EXPECT_EQ(result.keyframes_fused, 3u);
  const PlyCloud cloud = ReadPly(options.out);
  ASSERT_EQ(cloud.positions.size(), result.points);
  ASSERT_EQ(cloud.normals.size(), result.points);
  ASSERT_EQ(cloud.colors.size(), result.points);
  ExpectAccurate(Measure(scene_, cloud, options.voxel), options.voxel);
  bool has_producer = false;
  for (const std::string& comment : cloud.comments) {
    if (comment.rfind("producer rrslam-render", 0) == 0) has_producer = true;
  }
  EXPECT_TRUE(has_producer);
  // The picture beside the cloud, with its producer and options.
  const auto metadata = ReadPictureMetadata(dir_ / "model.png");
  bool software = false, options_recorded = false;
  for (const auto& [key, value] : metadata) {
    if (key == "Software" && value.find("rrslam-render") != std::string::npos) software = true;
    if (value.find("\"voxel\":0.01") != std::string::npos) options_recorded = true;
  }
  EXPECT_TRUE(software);
  EXPECT_TRUE(options_recorded);

  // ASCII PLY, picture elsewhere: the same points.
  options.binary = false;
  options.out = dir_ / "ascii.ply";
  options.image = dir_ / "view.png";
  const DenseResult again = RunDense(options);
  EXPECT_EQ(again.points, result.points);
  EXPECT_EQ(ReadPly(options.out).positions.size(), result.points);
  EXPECT_TRUE(fs::exists(dir_ / "view.png"));
  EXPECT_FALSE(fs::exists(dir_ / "ascii.png"));
}

TEST_F(DenseRun, UndistortsImagesOfADistortedCamera) {
  Distortion distortion;
  distortion.k1 = -0.25;
  distortion.k2 = 0.08;
  distortion.p1 = 0.002;
  distortion.p2 = -0.001;
  WriteSequenceAndMap(scene_, dir_ / "seq", dir_ / "map.rrm", distortion);
  const DenseOptions options = TestOptions(dir_);
  const DenseResult result = RunDense(options);
  EXPECT_EQ(result.keyframes_fused, 3u);
  ExpectAccurate(Measure(scene_, ReadPly(options.out), options.voxel), options.voxel);
}

TEST_F(DenseRun, MissingSequenceIsNoInput) {
  WriteSequenceAndMap(scene_, dir_ / "seq", dir_ / "map.rrm");
  DenseOptions options = TestOptions(dir_);
  options.sequence = dir_ / "nowhere";
  EXPECT_THROW(RunDense(options), NoInputError);
  options = TestOptions(dir_);
  options.map = dir_ / "none.rrm";
  EXPECT_THROW(RunDense(options), NoInputError);
  EXPECT_FALSE(fs::exists(options.out));
}

TEST_F(DenseRun, KeyframeWithoutFrameIsDataError) {
  WriteSequenceAndMap(scene_, dir_ / "seq", dir_ / "map.rrm");
  MapData map = ReadMapFile(dir_ / "map.rrm");
  map.keyframes[1].timestamp = 100.25;  // Between frames 2 and 3.
  WriteMapFile(dir_ / "map.rrm", map);
  const DenseOptions options = TestOptions(dir_);
  try {
    RunDense(options);
    FAIL() << "expected DataError";
  } catch (const DataError& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find("map.rrm"), std::string::npos) << message;
    EXPECT_NE(message.find("seq"), std::string::npos) << message;
    EXPECT_NE(message.find("1 of 3 keyframes"), std::string::npos) << message;
    EXPECT_NE(message.find("100.250000"), std::string::npos) << message;
  }
  EXPECT_FALSE(fs::exists(options.out));
  // Within the tolerance, it is found.
  map.keyframes[1].timestamp = 100.2 + 0.5 * kKeyFrameTimestampTolerance;
  WriteMapFile(dir_ / "map.rrm", map);
  EXPECT_EQ(RunDense(options).keyframes_fused, 3u);
}

TEST_F(DenseRun, TooLargeVolumeIsRefused) {
  WriteSequenceAndMap(scene_, dir_ / "seq", dir_ / "map.rrm");
  DenseOptions options = TestOptions(dir_);
  options.voxel = 0.001;
  options.max_volume_gb = 0.05;
  try {
    RunDense(options);
    FAIL() << "expected UsageError";
  } catch (const UsageError& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find("--voxel"), std::string::npos) << message;
    EXPECT_NE(message.find("--max-volume-gb"), std::string::npos) << message;
    EXPECT_EQ(message.find('\n'), std::string::npos) << message;
  }
  EXPECT_FALSE(fs::exists(options.out));
}

// A map with absurd values ends in a one-line typed error, never in an
// internal error (an OpenCV assertion) or a huge allocation: a keyframe 1e30 m
// away gives a volume that does not fit (the memory cap's message,
// UsageError, exit 64; its size overflowed int and went negative); a camera
// wider than kMaxImageSide (at 40000 x 40000 pixels the undistortion maps
// alone were 12 GB, and OpenCV's remap asserts from 32767) or with
// non-finite distortion is refused (DataError, exit 65); distortion
// coefficients of 1e6 give a (nearly empty) model or a typed error.
TEST_F(DenseRun, AbsurdMapValuesAreRefusedWithTypedErrors) {
  WriteSequenceAndMap(scene_, dir_ / "seq", dir_ / "map.rrm");
  const MapData good = ReadMapFile(dir_ / "map.rrm");
  const DenseOptions options = TestOptions(dir_);
  // The message of RunDense's error on `map`, "" when it succeeds.
  auto run = [&](const MapData& map) -> std::string {
    WriteMapFile(dir_ / "map.rrm", map);
    fs::remove(options.out);
    try {
      RunDense(options);
      return "";
    } catch (const UsageError& e) {
      return std::string("usage: ") + e.what();
    } catch (const DataError& e) {
      return std::string("data: ") + e.what();
    } catch (const AlgorithmError& e) {
      return std::string("algorithm: ") + e.what();
    } catch (const std::exception& e) {
      return std::string("internal: ") + e.what();
    }
  };
  for (const double far : {1e30, -1e30, 1e300}) {
    for (double MapPose::*axis : {&MapPose::tx, &MapPose::tz}) {
      MapData map = good;
      map.keyframes[1].T_cam_world.*axis = far;
      const std::string message = run(map);
      EXPECT_EQ(message.rfind("usage: the volume would be ", 0), 0u) << message;
      EXPECT_NE(message.find("above --max-volume-gb 3"), std::string::npos) << message;
      EXPECT_EQ(message.find('-', 6), message.find("--max-volume-gb"))
          << message;  // No "-2147...".
      EXPECT_EQ(message.find('\n'), std::string::npos) << message;
      EXPECT_FALSE(fs::exists(options.out));
    }
  }
  MapData map = good;
  map.camera.width = kMaxImageSide + 1;
  map.camera.k1 = 0.1;
  EXPECT_EQ(run(map), "data: " + (dir_ / "map.rrm").string() + ": camera image size 16385x" +
                          std::to_string(good.camera.height) + "; must be in [1, 16384] a side");
  map = good;
  map.camera.k2 = std::numeric_limits<double>::infinity();
  EXPECT_NE(run(map).find("data: "), std::string::npos);
  for (double MapCamera::*k :
       {&MapCamera::k1, &MapCamera::k2, &MapCamera::p1, &MapCamera::p2, &MapCamera::k3}) {
    for (const double value : {1e6, -1e6}) {
      map = good;
      map.camera.*k = value;
      const std::string message = run(map);
      EXPECT_EQ(message.find("internal: "), std::string::npos) << message;
      EXPECT_EQ(message.find('\n'), std::string::npos) << message;
    }
  }
}

TEST_F(DenseRun, MissingOutputFolderFailsFirst) {
  WriteSequenceAndMap(scene_, dir_ / "seq", dir_ / "map.rrm");
  DenseOptions options = TestOptions(dir_);
  options.out = dir_ / "no" / "model.ply";
  EXPECT_THROW(RunDense(options), CantCreateError);
}

// The executable: `rrslam-render dense` and its exit codes.
TEST_F(DenseRun, ExitCodes) {
  WriteSequenceAndMap(scene_, dir_ / "seq", dir_ / "map.rrm");
  const std::string inputs =
      "dense --map " + (dir_ / "map.rrm").string() + " --sequence " + (dir_ / "seq").string();
  const std::string out = " --out " + (dir_ / "m.ply").string() + " --image-width 64";
  auto ok = testing::RunTool("render", inputs + out);
  EXPECT_EQ(ok.exit_code, 0) << ok.output;
  EXPECT_NE(ok.output.find("3 keyframes fused"), std::string::npos) << ok.output;
  EXPECT_TRUE(fs::exists(dir_ / "m.ply"));
  EXPECT_TRUE(fs::exists(dir_ / "m.png"));
  EXPECT_EQ(testing::RunTool("render", inputs + out + " --voxel 0").exit_code, 64);
  EXPECT_EQ(
      testing::RunTool("render", inputs + out + " --voxel 0.001 --max-volume-gb 0.01").exit_code,
      64);
  EXPECT_EQ(testing::RunTool("render", "dense --map " + (dir_ / "map.rrm").string() +
                                           " --sequence " + (dir_ / "none").string() + out)
                .exit_code,
            66);
  MapData map = ReadMapFile(dir_ / "map.rrm");
  map.keyframes[2].timestamp = 99.0;
  WriteMapFile(dir_ / "map.rrm", map);
  EXPECT_EQ(testing::RunTool("render", inputs + out).exit_code, 65);
}

}  // namespace
}  // namespace rrslam
