#include "stages/render/dense/dense_model.h"

#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <iostream>
#include <limits>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/rgbd/volume.hpp>
#include <utility>
#include <vector>

#include "common/cli.h"
#include "common/clock.h"
#include "common/dataset.h"
#include "common/errors.h"
#include "common/image_io.h"
#include "common/json_text.h"
#include "common/output_path.h"
#include "common/text.h"
#include "stages/render/export_frame.h"
#include "stages/render/image_file.h"
#include "stages/render/keyframe_images.h"
#include "stages/render/map_scene.h"

namespace rrslam {
namespace fs = std::filesystem;
namespace {

// Bytes of one voxel of OpenCV's coloured TSDF (RGBTsdfVoxel in
// opencv_contrib modules/rgbd/src/colored_tsdf.hpp: int8 tsdf, uint8 weight,
// int16 r, g, b).
constexpr size_t kVoxelBytes = 8;
// OpenCV indexes the grid with int: at most 2^31 - 1 voxels.
constexpr double kMaxVoxels = 2147483647.0;
// Largest weight of a voxel's running average (KinectFusion's and OpenCV's
// default; OpenCV requires < 255). Views beyond it count as a moving average.
constexpr int kMaxWeight = 64;
// Raycast step as a fraction of the truncation distance: half the band (OpenCV
// defaults to a quarter; half still samples the band behind a surface twice at
// the narrowest truncation, 2.1 voxels, and halves the rendering time).
constexpr float kRaycastStepFactor = 0.5f;
// Rendering: horizontal field of view and the fraction of surface points
// that must be in view.
constexpr double kViewFovDegrees = 66.0;
constexpr double kViewCoverage = 0.98;

constexpr double kGiB = 1024.0 * 1024.0 * 1024.0;

bool Fail(std::string* why, const std::string& text) {
  if (why != nullptr) *why = text;
  return false;
}

// Sets OpenCV's worker threads for a scope.
class OpenCvThreads {
 public:
  explicit OpenCvThreads(int threads) : previous_(cv::getNumThreads()) {
    cv::setNumThreads(threads);
  }
  ~OpenCvThreads() { cv::setNumThreads(previous_); }
  OpenCvThreads(const OpenCvThreads&) = delete;
  OpenCvThreads& operator=(const OpenCvThreads&) = delete;

 private:
  int previous_;
};

cv::Matx44f ToMatx(const Rigid3d& T) {
  const Eigen::Matrix4d m = T.ToMatrix();
  cv::Matx44f out;
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) out(r, c) = static_cast<float>(m(r, c));
  }
  return out;
}

// Zeroes depth beyond `max_depth` and anything not a positive finite number
// (OpenCV's integration treats 0 as "no measurement").
void ClipDepth(cv::Mat* depth, float max_depth) {
  for (int v = 0; v < depth->rows; ++v) {
    float* row = depth->ptr<float>(v);
    for (int u = 0; u < depth->cols; ++u) {
      if (!(row[u] > 0.0f && row[u] <= max_depth)) row[u] = 0.0f;
    }
  }
}

void CheckImages(const KeyFrameView& view, const KeyFrameCamera& camera, size_t index,
                 bool with_color) {
  if (view.depth.type() != CV_32FC1 || view.depth.cols != camera.width ||
      view.depth.rows != camera.height) {
    throw DataError("view " + std::to_string(index) + ": depth is " +
                    std::to_string(view.depth.cols) + "x" + std::to_string(view.depth.rows) +
                    " (type " + std::to_string(view.depth.type()) + "); the camera is " +
                    std::to_string(camera.width) + "x" + std::to_string(camera.height) +
                    " CV_32FC1");
  }
  if (with_color && (view.color.type() != CV_8UC3 || view.color.size() != view.depth.size())) {
    throw DataError("view " + std::to_string(index) + ": colour is " +
                    std::to_string(view.color.cols) + "x" + std::to_string(view.color.rows) +
                    "; must be 8-bit BGR of the depth's size");
  }
}

// The value at `fraction` of the sorted `values` (values is reordered).
double Quantile(std::vector<double>* values, double fraction) {
  if (values->empty()) return 0;
  const size_t k = std::min(values->size() - 1, static_cast<size_t>(fraction * values->size()));
  std::nth_element(values->begin(), values->begin() + static_cast<std::ptrdiff_t>(k),
                   values->end());
  return (*values)[k];
}

// The rendering's viewpoint (see BuildDenseModel in the header).
Rigid3d ChooseView(const std::vector<Rigid3d>& poses, const PlyCloud& cloud, double tan_half_x,
                   double tan_half_y) {
  // Robust centre: middle of the 2%..98% range of the points on each axis.
  const size_t stride = std::max<size_t>(1, cloud.positions.size() / 200000);
  std::vector<Eigen::Vector3d> sample;
  for (size_t i = 0; i < cloud.positions.size(); i += stride) {
    sample.push_back(cloud.positions[i].cast<double>());
  }
  Eigen::Vector3d centre;
  for (int axis = 0; axis < 3; ++axis) {
    std::vector<double> values;
    values.reserve(sample.size());
    for (const Eigen::Vector3d& p : sample) values.push_back(p[axis]);
    centre[axis] = 0.5 * (Quantile(&values, 0.02) + Quantile(&values, 0.98));
  }
  // Mean viewing and up directions of the keyframes (camera z forward, y down).
  Eigen::Vector3d forward = Eigen::Vector3d::Zero(), up = Eigen::Vector3d::Zero();
  for (const Rigid3d& T : poses) {
    const Eigen::Matrix3d R = T.RotationMatrix();
    forward += R.col(2);
    up -= R.col(1);
  }
  if (forward.norm() < 0.2 * static_cast<double>(poses.size())) {
    forward = poses.front().RotationMatrix().col(2);  // Views all around: the first one's.
  }
  forward.normalize();
  up -= up.dot(forward) * forward;
  if (up.norm() < 1e-6) up = forward.unitOrthogonal();
  up.normalize();
  Eigen::Matrix3d R_world_view;
  R_world_view.col(2) = forward;
  R_world_view.col(1) = -up;
  R_world_view.col(0) = R_world_view.col(1).cross(R_world_view.col(2));
  // Back off along -forward until kViewCoverage of the points are in view
  // (with a 5% border).
  std::vector<double> needed;
  needed.reserve(sample.size());
  const double tx = 0.95 * tan_half_x, ty = 0.95 * tan_half_y;
  for (const Eigen::Vector3d& p : sample) {
    const Eigen::Vector3d r = R_world_view.transpose() * (p - centre);
    needed.push_back(std::max(std::abs(r.x()) / tx, std::abs(r.y()) / ty) - r.z());
  }
  const double distance = std::max(0.1, Quantile(&needed, kViewCoverage));
  return Rigid3d(Eigen::Quaterniond(R_world_view).normalized(), centre - distance * forward);
}

// Colours of surface samples (world points with normals) from the views
// that see them: each view's colour at the sample's projection, where the
// view's depth there agrees with the sample's within `tolerance` (not
// occluded), weighted by the squared cosine between the normal and the ray
// (frontal views count most). The views that see a sample from behind its
// normal are kept apart: a sample that only such views see has its normal
// the wrong way round (the TSDF's gradient at thin parts, edges and
// clutter), and FacesAway() says so; its colour comes from those views.
//
// Why not the volume's colours alone: OpenCV 4.6's COLOREDTSDF keeps one
// colour per voxel, and getColorVoxel (raycast, fetchPointsNormalsColors)
// blends the 8 voxels around a point with weights computed in the wrong
// units (colored_tsdf.cpp: `p * voxelSizeInv` of a point already in voxels),
// including voxels no view reached, whose colour is 0: thin black seams along
// every surface seen at a grazing angle, and a texture blurred to 1-2 voxels.
// The volume's colour remains the fallback for a sample no view sees.
class ColorAccumulator {
 public:
  void Reserve(size_t n) {
    points_.reserve(n);
    normals_.reserve(n);
  }
  // Adds a sample; returns its index.
  size_t AddSample(const Eigen::Vector3f& point_world, const Eigen::Vector3f& normal_world) {
    points_.push_back(point_world);
    normals_.push_back(normal_world);
    return points_.size() - 1;
  }

  // Adds one view's colours (depth: clipped metres; color: BGR).
  void AddView(const cv::Mat& depth, const cv::Mat& color, const Rigid3d& T_world_cam,
               const KeyFrameCamera& camera, double tolerance) {
    if (sums_.size() != points_.size()) sums_.assign(points_.size(), Eigen::Vector4f::Zero());
    if (behind_.size() != points_.size()) behind_.assign(points_.size(), Eigen::Vector4f::Zero());
    const Rigid3d T_cam_world = T_world_cam.Inverse();
    const Eigen::Matrix3f R = T_cam_world.RotationMatrix().cast<float>();
    const Eigen::Vector3f t = T_cam_world.translation.cast<float>();
    const Eigen::Vector3f centre = T_world_cam.translation.cast<float>();
    const float fx = static_cast<float>(camera.fx), fy = static_cast<float>(camera.fy);
    const float cx = static_cast<float>(camera.cx), cy = static_cast<float>(camera.cy);
    const float max_u = static_cast<float>(depth.cols - 1);
    const float max_v = static_cast<float>(depth.rows - 1);
    const float tol = static_cast<float>(tolerance);
    cv::parallel_for_(cv::Range(0, static_cast<int>(points_.size())), [&](const cv::Range& r) {
      for (int i = r.start; i < r.end; ++i) {
        const Eigen::Vector3f& p = points_[i];
        const Eigen::Vector3f p_cam = R * p + t;
        if (!(p_cam.z() > 0)) continue;  // Also skips NaN samples.
        const float u = fx * p_cam.x() / p_cam.z() + cx;
        const float v = fy * p_cam.y() / p_cam.z() + cy;
        if (!(u >= 0 && v >= 0 && u <= max_u && v <= max_v)) continue;
        const float d = depth.at<float>(static_cast<int>(v + 0.5f), static_cast<int>(u + 0.5f));
        if (d == 0 || std::abs(d - p_cam.z()) > tol) continue;
        const float cosine = normals_[i].dot((centre - p).normalized());
        if (!std::isfinite(cosine) || cosine == 0) continue;
        // Bilinear colour at (u, v).
        const int u0 = std::min(static_cast<int>(u), depth.cols - 2);
        const int v0 = std::min(static_cast<int>(v), depth.rows - 2);
        const float a = u - u0, b = v - v0;
        const cv::Vec3b* row0 = color.ptr<cv::Vec3b>(v0);
        const cv::Vec3b* row1 = color.ptr<cv::Vec3b>(v0 + 1);
        Eigen::Vector4f sample;
        for (int k = 0; k < 3; ++k) {
          sample[k] = (1 - b) * ((1 - a) * row0[u0][2 - k] + a * row0[u0 + 1][2 - k]) +
                      b * ((1 - a) * row1[u0][2 - k] + a * row1[u0 + 1][2 - k]);
        }
        sample[3] = 1;
        (cosine > 0 ? sums_[i] : behind_[i]) += cosine * cosine * sample;
      }
    });
  }

  // Whether only views from behind its normal saw sample i.
  bool FacesAway(size_t i) const {
    return i < sums_.size() && !(sums_[i][3] > 0) && behind_[i][3] > 0;
  }

  // The RGB average of sample i over the views in front of its normal (or,
  // when it FacesAway, behind it); false when no view saw it.
  bool Get(size_t i, Eigen::Vector3f* rgb) const {
    if (i >= sums_.size()) return false;
    const Eigen::Vector4f& sum = FacesAway(i) ? behind_[i] : sums_[i];
    if (!(sum[3] > 0)) return false;
    *rgb = sum.head<3>() / sum[3];
    return true;
  }

 private:
  std::vector<Eigen::Vector3f> points_, normals_;
  // Weighted R, G, B and the weight, of the views in front of each sample's
  // normal and of those behind it.
  std::vector<Eigen::Vector4f> sums_, behind_;
};

// Frames the points in a width x height picture from `T_world_view`: the
// focal length and principal point that fit the 1%..99% range of their
// projections to 95% of the picture, centred (an off-centre principal point
// is a shifted lens: the view direction stays). Returns {f, cx, cy}.
Eigen::Vector3d FrameView(const Rigid3d& T_world_view, const PlyCloud& cloud, int width, int height,
                          double default_f) {
  const Rigid3d T_view_world = T_world_view.Inverse();
  const size_t stride = std::max<size_t>(1, cloud.positions.size() / 200000);
  std::vector<double> xs, ys;
  for (size_t i = 0; i < cloud.positions.size(); i += stride) {
    const Eigen::Vector3d p = T_view_world * cloud.positions[i].cast<double>();
    if (p.z() < 0.05) continue;
    xs.push_back(p.x() / p.z());
    ys.push_back(p.y() / p.z());
  }
  if (xs.size() < 10) return {default_f, 0.5 * (width - 1), 0.5 * (height - 1)};
  const double x0 = Quantile(&xs, 0.01), x1 = Quantile(&xs, 0.99);
  const double y0 = Quantile(&ys, 0.01), y1 = Quantile(&ys, 0.99);
  const double f =
      std::min(0.95 * width / std::max(x1 - x0, 1e-6), 0.95 * height / std::max(y1 - y0, 1e-6));
  return {f, 0.5 * (width - 1) - f * 0.5 * (x0 + x1), 0.5 * (height - 1) - f * 0.5 * (y0 + y1)};
}

// Shades the raycast (camera-frame points and normals, colours RGB 0..255)
// into a BGR picture: colour x (ambient + headlight + key light from the
// upper left), on a dark vertical gradient. The shading normal is the mean of
// the normals within 2 pixels whose points lie within `smooth_radius` metres
// (edges stay sharp): a Kinect's depth quantization leaves ripples of about a
// voxel on flat surfaces, which a raw normal would draw as dark seams.
cv::Mat Shade(const cv::Mat& points, const cv::Mat& normals, const cv::Mat& colors,
              float smooth_radius) {
  cv::Mat picture(points.size(), CV_8UC3);
  const Eigen::Vector3f key = Eigen::Vector3f(-0.5f, -0.8f, -0.6f).normalized();
  constexpr int kHalf = 2;
  const float radius2 = smooth_radius * smooth_radius;
  cv::parallel_for_(cv::Range(0, points.rows), [&](const cv::Range& rows) {
    for (int v = rows.start; v < rows.end; ++v) {
      cv::Vec3b* out = picture.ptr<cv::Vec3b>(v);
      const float t = static_cast<float>(v) / static_cast<float>(std::max(1, points.rows - 1));
      const cv::Vec3b background(static_cast<uint8_t>(58 - 30 * t),
                                 static_cast<uint8_t>(50 - 26 * t),
                                 static_cast<uint8_t>(46 - 24 * t));
      for (int u = 0; u < points.cols; ++u) {
        const cv::Vec4f& p = points.at<cv::Vec4f>(v, u);
        const Eigen::Vector3f point(p[0], p[1], p[2]);
        const cv::Vec4f& n0 = normals.at<cv::Vec4f>(v, u);
        if (!point.allFinite() || !Eigen::Vector3f(n0[0], n0[1], n0[2]).allFinite()) {
          out[u] = background;
          continue;
        }
        Eigen::Vector3f normal = Eigen::Vector3f::Zero();
        for (int dv = -kHalf; dv <= kHalf; ++dv) {
          const int y = v + dv;
          if (y < 0 || y >= points.rows) continue;
          for (int du = -kHalf; du <= kHalf; ++du) {
            const int x = u + du;
            if (x < 0 || x >= points.cols) continue;
            const cv::Vec4f& q = points.at<cv::Vec4f>(y, x);
            const cv::Vec4f& m = normals.at<cv::Vec4f>(y, x);
            const Eigen::Vector3f nm(m[0], m[1], m[2]);
            if (!nm.allFinite()) continue;
            if ((Eigen::Vector3f(q[0], q[1], q[2]) - point).squaredNorm() > radius2) continue;
            normal += nm;
          }
        }
        normal.normalize();
        const Eigen::Vector3f to_eye = -point.normalized();
        const float head = std::abs(normal.dot(to_eye));
        const float side = std::max(0.0f, normal.dot(key));
        const float shade = 0.42f + 0.45f * head + 0.25f * side;
        const cv::Vec4f& c = colors.at<cv::Vec4f>(v, u);
        Eigen::Vector3f rgb(c[0], c[1], c[2]);
        if (!rgb.allFinite()) rgb.setConstant(160.0f);
        for (int k = 0; k < 3; ++k) {
          out[u][2 - k] = cv::saturate_cast<uint8_t>(rgb[k] * shade);
        }
      }
    }
  });
  return picture;
}

}  // namespace

// ---------------------------------------------------------------------------
// Volume axes

// The volume's axes in the world (columns x, y, z of R_world_volume).
//
// OpenCV 4.6 (and contrib up to 4.9 at least) integrates a column of voxels
// (x, y, 0..n) by stepping a camera-frame point from voxel z = 0 but starting
// the loop at `startZ`, the first voxel in front of the camera when the
// column's base is behind it, without advancing the point to it
// (integrateVolumeUnit / integrateRGBVolumeUnit in
// modules/rgbd/src/tsdf_functions.cpp: `camSpacePt += zStep` from basePt). So
// voxel z receives the TSDF of position z - startZ + 1. startZ is 0 (and the
// shift a constant voxel, corrected at export) for every column exactly when
// the volume's z axis does not point along the camera's optical axis
// (zStep.z = voxel * (optical axis . z axis) <= 0). The z axis is therefore
// chosen against every view's optical axis: the keyframes' mean up direction
// when every view looks level or down, else the direction of largest margin
// (searched over a Fibonacci sphere). `views_against` receives the number of
// views no direction suits (a map whose views look every way, up and down too).
// They are fused anyway, with a warning: in the columns whose base is behind
// such a camera, voxels receive the TSDF of points lower in the column. For a
// view nearly perpendicular to the axis those points lie outside its image
// (it only misses voxels close to the camera); the steeper the view looks
// along the axis, the more of what it sees may be misplaced.
Eigen::Matrix3d ChooseDenseVolumeAxes(const std::vector<Rigid3d>& T_world_cams,
                                      size_t* views_against) {
  std::vector<Eigen::Vector3d> axes;
  Eigen::Vector3d up = Eigen::Vector3d::Zero();
  for (const Rigid3d& T : T_world_cams) {
    const Eigen::Matrix3d R = T.RotationMatrix();
    axes.push_back(R.col(2));
    up -= R.col(1);
  }
  auto margin = [&](const Eigen::Vector3d& z) {
    double worst = std::numeric_limits<double>::infinity();
    for (const Eigen::Vector3d& d : axes) worst = std::min(worst, -d.dot(z));
    return worst;
  };
  // OpenCV treats |zStep.z| <= 1e-5 m as a column parallel to the image plane
  // (safe); 1e-6 is within that for any voxel up to 10 m.
  constexpr double kParallel = 1e-6;
  // sin(1 degree): a view nearly perpendicular to the axis is still safe, but
  // float rounding of the pose should not flip it.
  constexpr double kSafeMargin = 0.017;
  Eigen::Vector3d z = up.norm() > 1e-9 ? up.normalized() : Eigen::Vector3d::UnitZ();
  if (margin(z) < kSafeMargin) {
    constexpr int kCandidates = 4096;
    const double golden = M_PI * (3.0 - std::sqrt(5.0));
    double best = -std::numeric_limits<double>::infinity();
    for (int i = 0; i < kCandidates; ++i) {
      const double y = 1.0 - 2.0 * (i + 0.5) / kCandidates;
      const double r = std::sqrt(1.0 - y * y);
      const Eigen::Vector3d candidate(r * std::cos(golden * i), y, r * std::sin(golden * i));
      const double m = margin(candidate);
      if (m > best) {
        best = m;
        z = candidate;
      }
    }
    // Refined by steps towards the tangent directions (the candidates are
    // about 3 degrees apart).
    for (double step = 0.03; step > 1e-4; step *= 0.5) {
      bool improved = true;
      while (improved) {
        improved = false;
        const Eigen::Vector3d a = z.unitOrthogonal(), b = z.cross(a);
        const Eigen::Vector3d directions[8] = {a, -a, b, -b, a + b, a - b, b - a, -a - b};
        for (const Eigen::Vector3d& direction : directions) {
          const Eigen::Vector3d candidate = (z + step * direction).normalized();
          const double m = margin(candidate);
          if (m > best + 1e-12) {
            best = m;
            z = candidate;
            improved = true;
          }
        }
      }
    }
  }
  *views_against = 0;
  for (const Eigen::Vector3d& d : axes) {
    if (d.dot(z) > kParallel) ++*views_against;
  }
  // x: the world's x axis (else y) made perpendicular to z.
  Eigen::Vector3d x = Eigen::Vector3d::UnitX() - z.x() * z;
  if (x.norm() < 0.1) x = Eigen::Vector3d::UnitY() - z.y() * z;
  x.normalize();
  Eigen::Matrix3d R_world_volume;
  R_world_volume.col(0) = x;
  R_world_volume.col(1) = z.cross(x);
  R_world_volume.col(2) = z;
  return R_world_volume;
}

// ---------------------------------------------------------------------------
// Options

fs::path DenseOptions::ImagePath() const {
  if (!image.empty()) return image;
  fs::path path = out;
  return path.replace_extension(".png");
}

bool DenseOptions::Check(std::string* why) const {
  if (map.empty()) return Fail(why, "--map is empty; a map file (rrslam.map) is required");
  if (sequence.empty()) {
    return Fail(why, "--sequence is empty; the RGB-D sequence folder of the map is required");
  }
  if (out.empty()) return Fail(why, "--out is empty; an output point cloud (.ply) is required");
  if (AsciiLowercase(out.extension().string()) != ".ply") {
    return Fail(why, "--out " + out.string() + " must be a .ply file");
  }
  if (AsciiLowercase(ImagePath().extension().string()) != ".png") {
    return Fail(why, "--image " + ImagePath().string() + " must be a .png file");
  }
  const std::vector<NamedPath> inputs = {
      {"--map", map}, {"--sequence", sequence}, {"--associations", associations}};
  if (!CheckOutputs({{"--out", out}, {"--image", ImagePath()}}, inputs, why)) return false;
  if (!(voxel > 0) || !std::isfinite(voxel)) {
    return Fail(why, "--voxel = " + Format("%g", voxel) + "; must be > 0 metres");
  }
  if (!(truncation >= 0) || !std::isfinite(truncation)) {
    return Fail(why, "--truncation = " + Format("%g", truncation) +
                         "; must be 0 (4 voxels) or a distance in metres");
  }
  if (truncation > 0 && truncation < 2.1 * voxel) {
    return Fail(why, "--truncation = " + Format("%g", truncation) + "; must be >= 2.1 voxels (" +
                         Format("%g", 2.1 * voxel) + " m), OpenCV's narrowest band");
  }
  if (!(max_depth > 0) || !std::isfinite(max_depth)) {
    return Fail(why, "--max-depth = " + Format("%g", max_depth) + "; must be > 0 metres");
  }
  if (!(max_volume_gb > 0 && max_volume_gb < 16)) {
    return Fail(why, "--max-volume-gb = " + Format("%g", max_volume_gb) +
                         "; must be in (0, 16) (OpenCV indexes at most 2^31 voxels)");
  }
  if (image_width < 64 || image_width > 8192) {
    return Fail(why, "--image-width = " + std::to_string(image_width) + "; must be in [64, 8192]");
  }
  if (threads < 1 || threads > 64) {
    return Fail(why, "--threads = " + std::to_string(threads) + "; must be in [1, 64]");
  }
  return CheckFrameName(frame, why);
}

nlohmann::ordered_json DenseOptions::ToJson() const {
  return {{"map", map.string()},
          {"sequence", sequence.string()},
          {"associations", associations.string()},
          {"out", out.string()},
          {"image", ImagePath().string()},
          {"voxel", voxel},
          {"truncation", EffectiveTruncation()},
          {"max_depth", max_depth},
          {"binary", binary},
          {"max_volume_gb", max_volume_gb},
          {"image_width", image_width},
          {"threads", threads},
          {"frame", frame}};
}

void BindDenseOptions(CLI::App* command, DenseOptions* o) {
  command->add_option("--map", o->map, "Map file (rrslam.map) whose keyframes are fused")
      ->required();
  command
      ->add_option("--sequence", o->sequence,
                   "TUM RGB-D sequence folder the map was built from (keyframes are found in it "
                   "by timestamp)")
      ->required();
  command->add_option("--associations", o->associations,
                      "Associations file, absolute or relative to the sequence (as given to "
                      "rrslam-track); default: rgb.txt paired with depth.txt");
  command
      ->add_option("--out", o->out, "Output point cloud (.ply): surface points, normals, colours")
      ->required();
  command->add_option("--image", o->image,
                      "Output rendering (.png); default: --out with the extension .png");
  command->add_option("--voxel", o->voxel, "Voxel edge, metres")->capture_default_str();
  command
      ->add_option("--truncation", o->truncation,
                   "TSDF truncation distance, metres (0 = 4 voxels; at least 2.1 voxels)")
      ->capture_default_str();
  command->add_option("--max-depth", o->max_depth, "Depth beyond this many metres is ignored")
      ->capture_default_str();
  command->add_flag("--binary,!--ascii", o->binary,
                    "PLY as binary little-endian (default) or --ascii");
  command
      ->add_option("--max-volume-gb", o->max_volume_gb,
                   "Largest voxel grid, GiB (8 bytes a voxel); a larger volume is refused")
      ->capture_default_str();
  command
      ->add_option("--image-width", o->image_width,
                   "Width of the rendering, pixels (height: the camera's aspect ratio)")
      ->capture_default_str();
  command->add_option("--threads", o->threads, "OpenCV worker threads")->capture_default_str();
  AddFrameOption(command, &o->frame);
}

nlohmann::ordered_json DenseResult::ToJson() const {
  auto vec = [](const auto& v) { return nlohmann::ordered_json{v[0], v[1], v[2]}; };
  const Eigen::Vector3d view_position = T_world_view.translation;
  const Eigen::Vector3d view_forward = T_world_view.RotationMatrix().col(2);
  return {{"keyframes_fused", keyframes_fused},
          {"views_against_axis", views_against_axis},
          {"points", points},
          {"points_without_normal", points_without_normal},
          {"points_colored_by_volume", points_colored_by_volume},
          {"normals_flipped", normals_flipped},
          {"depth_bounds_min", vec(depth_bounds.min())},
          {"depth_bounds_max", vec(depth_bounds.max())},
          {"volume_origin", vec(volume_origin)},
          {"volume_z_axis", vec(Eigen::Vector3d(R_world_volume.col(2)))},
          {"resolution", vec(resolution)},
          {"voxel", voxel},
          {"truncation", truncation},
          {"volume_bytes", volume_bytes},
          {"view_position", vec(view_position)},
          {"view_forward", vec(view_forward)},
          {"view_fx", view_fx},
          {"view_cx", view_cx},
          {"view_cy", view_cy},
          {"bounds_seconds", bounds_seconds},
          {"fuse_seconds", fuse_seconds},
          {"export_seconds", export_seconds},
          {"color_seconds", color_seconds},
          {"write_seconds", write_seconds}};
}

// ---------------------------------------------------------------------------
// The model

DenseModel BuildDenseModel(const DenseOptions& options, const KeyFrameCamera& camera,
                           const std::vector<Rigid3d>& T_world_cams, const DenseImageLoader& load) {
  const size_t count = T_world_cams.size();
  if (count == 0) throw DataError("no views to fuse");
  if (!(camera.fx > 0 && camera.fy > 0) || camera.width <= 0 || camera.height <= 0) {
    throw DataError("the camera has no valid intrinsics (fx " + Format("%g", camera.fx) +
                    ", size " + std::to_string(camera.width) + "x" + std::to_string(camera.height) +
                    ")");
  }
  const OpenCvThreads threads(options.threads);
  DenseModel model;
  DenseResult& result = model.result;
  const float max_depth = static_cast<float>(options.max_depth);
  const double voxel = options.voxel;
  const double truncation = options.EffectiveTruncation();
  result.voxel = voxel;
  result.truncation = truncation;
  result.R_world_volume = ChooseDenseVolumeAxes(T_world_cams, &result.views_against_axis);
  if (result.views_against_axis > 0) {
    spdlog::warn(
        "dense: {} of {} views look along every volume axis tried (the views look all "
        "around); OpenCV 4.6 may misplace parts of what they see",
        result.views_against_axis, count);
  }
  const Eigen::Matrix3d R_volume_world = result.R_world_volume.transpose();
  spdlog::debug("dense: volume z axis {:.3f} {:.3f} {:.3f} (world)", result.R_world_volume(0, 2),
                result.R_world_volume(1, 2), result.R_world_volume(2, 2));

  // Pass 1: the volume bounds (volume frame), from every depth point within
  // max_depth.
  auto start = SteadyClock::now();
  for (size_t i = 0; i < count; ++i) {
    KeyFrameView images = load(i, false);
    CheckImages(images, camera, i, false);
    ClipDepth(&images.depth, max_depth);
    const Eigen::Matrix3d R = R_volume_world * T_world_cams[i].RotationMatrix();
    const Eigen::Vector3d t = R_volume_world * T_world_cams[i].translation;
    for (int v = 0; v < images.depth.rows; ++v) {
      const float* row = images.depth.ptr<float>(v);
      for (int u = 0; u < images.depth.cols; ++u) {
        const double z = row[u];
        if (z == 0) continue;
        const Eigen::Vector3d point_cam((u - camera.cx) * z / camera.fx,
                                        (v - camera.cy) * z / camera.fy, z);
        result.depth_bounds.extend(R * point_cam + t);
      }
    }
  }
  result.bounds_seconds = MillisecondsSince(start) / 1000.0;
  if (result.depth_bounds.isEmpty()) {
    throw DataError("no depth within --max-depth " + Format("%g", options.max_depth) +
                    " m in any of the " + std::to_string(count) + " views");
  }

  // The volume: the bounds plus the truncation band behind the farthest
  // surfaces and two voxels for the normals' central differences.
  const double margin = truncation + 2 * voxel;
  const Eigen::Vector3d corner = result.depth_bounds.min() - Eigen::Vector3d::Constant(margin);
  const Eigen::Vector3d extent =
      result.depth_bounds.sizes() + Eigen::Vector3d::Constant(2 * margin);
  // In doubles, checked before anything becomes an int: the bounds come from
  // the data, and a keyframe 1e30 m away must give the cap's message, not an
  // int overflow (a negative resolution, an OpenCV assertion).
  double cells[3];
  double voxels = 1;
  for (int axis = 0; axis < 3; ++axis) {
    cells[axis] = std::ceil(extent[axis] / voxel) + 1;
    voxels *= cells[axis];
  }
  const double bytes = voxels * kVoxelBytes;
  if (!(bytes <= options.max_volume_gb * kGiB) || !(voxels <= kMaxVoxels)) {
    // The voxel at which the volume would fit (volume ~ 1 / voxel^3).
    const double cap = std::min(options.max_volume_gb * kGiB, kMaxVoxels * kVoxelBytes);
    const double fits = std::ceil(voxel * std::cbrt(bytes / cap) * 1.02 * 1000.0) / 1000.0;
    const auto count = [](double n) { return Format(n < 1e9 ? "%.0f" : "%.3g", n); };
    throw UsageError("the volume would be " + count(cells[0]) + " x " + count(cells[1]) + " x " +
                     count(cells[2]) + " voxels of " + Format("%g", voxel) + " m (" +
                     Format(bytes / kGiB < 1e9 ? "%.1f" : "%.3g", bytes / kGiB) +
                     " GiB), above --max-volume-gb " + Format("%g", options.max_volume_gb) +
                     (std::isfinite(fits) ? "; use --voxel " + Format("%g", fits) +
                                                " or larger, or a smaller --max-depth"
                                          : std::string("; the views lie too far apart")));
  }
  for (int axis = 0; axis < 3; ++axis) result.resolution[axis] = static_cast<int>(cells[axis]);
  result.volume_origin = result.R_world_volume * corner;
  result.volume_bytes = static_cast<size_t>(bytes);
  spdlog::info("dense: volume {} x {} x {} voxels of {} m ({:.0f} MB), truncation {} m",
               result.resolution.x(), result.resolution.y(), result.resolution.z(), voxel,
               bytes / 1e6, truncation);

  start = SteadyClock::now();
  // Voxel (i, j, k) of OpenCV's volume is at volume pose * ((i, j, k) *
  // voxel): the pose maps the volume frame, origin at the centre of voxel
  // (0, 0, 0), to the world.
  const Rigid3d T_world_volume(Eigen::Quaterniond(result.R_world_volume).normalized(),
                               result.volume_origin);
  const cv::Ptr<cv::kinfu::Volume> volume = cv::kinfu::makeVolume(
      cv::kinfu::VolumeType::COLOREDTSDF, static_cast<float>(voxel), ToMatx(T_world_volume),
      kRaycastStepFactor, static_cast<float>(truncation), kMaxWeight, 0.0f,
      cv::Vec3i(result.resolution.x(), result.resolution.y(), result.resolution.z()));

  // Pass 2: fusion. Depth in metres (depth factor 1); colour as CV_32FC4
  // RGB0 in 0..255, the type COLOREDTSDF reads. The same intrinsics for depth
  // and colour: the sequence's images are registered. (OpenCV 4.6's SIMD path
  // projects colour with the depth intrinsics anyway.)
  const cv::kinfu::Intr intrinsics(static_cast<float>(camera.fx), static_cast<float>(camera.fy),
                                   static_cast<float>(camera.cx), static_cast<float>(camera.cy));
  cv::Mat rgba, rgba_float;
  for (size_t i = 0; i < count; ++i) {
    KeyFrameView images = load(i, true);
    CheckImages(images, camera, i, true);
    ClipDepth(&images.depth, max_depth);
    cv::cvtColor(images.color, rgba, cv::COLOR_BGR2RGBA);
    rgba.convertTo(rgba_float, CV_32FC4);
    volume->integrate(images.depth, rgba_float, 1.0f, ToMatx(T_world_cams[i]), intrinsics,
                      intrinsics, static_cast<int>(i));
    ++result.keyframes_fused;
  }
  result.fuse_seconds = MillisecondsSince(start) / 1000.0;

  // Surface points. Two offsets of OpenCV's grid (volume frame, voxels):
  //  - integration: voxel (i, j, k) holds the TSDF of position (i, j, k + 1)
  //    (ChooseDenseVolumeAxes), so the surface in the grid lies one voxel below
  //    the scene along the volume's z;
  //  - fetchPointsNormalsColors puts a zero crossing between voxels i and
  //    i + 1 at (i + 0.5 + s) * voxel, half a voxel beyond the grid on every
  //    axis (raycast and fetchNormals use i * voxel).
  // The fetched points are moved onto the grid (-1/2, -1/2, -1/2), where
  // their normals are taken (fetchNormals), then onto the scene (0, 0, +1).
  start = SteadyClock::now();
  cv::Mat points, normals, colors;
  volume->fetchPointsNormalsColors(points, cv::noArray(), colors);
  const Eigen::Vector3f to_grid =
      (result.R_world_volume * Eigen::Vector3d(-0.5, -0.5, -0.5) * voxel).cast<float>();
  const Eigen::Vector3f to_scene =
      (result.R_world_volume * Eigen::Vector3d(0, 0, 1) * voxel).cast<float>();
  for (int i = 0; i < points.rows; ++i) {
    cv::Vec4f& p = points.at<cv::Vec4f>(i);
    for (int k = 0; k < 3; ++k) p[k] += to_grid[k];
  }
  if (points.rows > 0) volume->fetchNormals(points, normals);
  spdlog::debug("dense: {} surface points fetched in {:.2f} s", points.rows,
                MillisecondsSince(start) / 1000.0);
  PlyCloud& cloud = model.cloud;
  cloud.positions.reserve(points.rows);
  cloud.normals.reserve(points.rows);
  cloud.colors.reserve(points.rows);
  for (int i = 0; i < points.rows; ++i) {
    const cv::Vec4f& p = points.at<cv::Vec4f>(i);
    const cv::Vec4f& n = normals.at<cv::Vec4f>(i);
    const cv::Vec4f& c = colors.at<cv::Vec4f>(i);
    const Eigen::Vector3f normal(n[0], n[1], n[2]);
    if (!normal.allFinite()) {
      ++result.points_without_normal;
      continue;
    }
    cloud.positions.push_back(Eigen::Vector3f(p[0], p[1], p[2]) + to_scene);
    cloud.normals.push_back(normal.normalized());
    std::array<uint8_t, 3> rgb{};
    for (int k = 0; k < 3; ++k) {
      rgb[k] = std::isfinite(c[k]) ? cv::saturate_cast<uint8_t>(c[k]) : uint8_t{160};
    }
    cloud.colors.push_back(rgb);
  }
  result.points = cloud.positions.size();
  if (result.points == 0) {
    throw AlgorithmError("the fused volume has no surface (" +
                         std::to_string(result.keyframes_fused) + " views fused)");
  }
  points.release();
  normals.release();
  colors.release();

  // The rendering: raycast from the chosen viewpoint.
  const int width = options.image_width;
  const int height = std::max(
      1, static_cast<int>(std::lround(width * static_cast<double>(camera.height) / camera.width)));
  const double tan_half_x = std::tan(0.5 * kViewFovDegrees * M_PI / 180.0);
  result.view_fx = 0.5 * width / tan_half_x;
  const double tan_half_y = 0.5 * height / result.view_fx;
  result.T_world_view = ChooseView(T_world_cams, cloud, tan_half_x, tan_half_y);
  const Eigen::Vector3d framing =
      FrameView(result.T_world_view, cloud, width, height, result.view_fx);
  result.view_fx = framing[0];
  result.view_cx = framing[1];
  result.view_cy = framing[2];
  const cv::kinfu::Intr view_intrinsics(
      static_cast<float>(result.view_fx), static_cast<float>(result.view_fx),
      static_cast<float>(result.view_cx), static_cast<float>(result.view_cy));
  cv::Mat ray_points, ray_normals, ray_colors;
  // The grid holds the scene one voxel down its z axis: so does the camera.
  // The points and normals come back in the camera's frame.
  Rigid3d T_grid_view = result.T_world_view;
  T_grid_view.translation -= to_scene.cast<double>();
  volume->raycast(ToMatx(T_grid_view), view_intrinsics, cv::Size(width, height), ray_points,
                  ray_normals, ray_colors);
  result.export_seconds = MillisecondsSince(start) / 1000.0;

  // Colours from the views (ColorAccumulator): the points, then the
  // rendering's pixels.
  start = SteadyClock::now();
  ColorAccumulator colors_from_views;
  colors_from_views.Reserve(cloud.positions.size() + static_cast<size_t>(width) * height);
  for (size_t i = 0; i < cloud.positions.size(); ++i) {
    colors_from_views.AddSample(cloud.positions[i], cloud.normals[i]);
  }
  const Eigen::Matrix3f R_world_view = result.T_world_view.RotationMatrix().cast<float>();
  const Eigen::Vector3f t_world_view = result.T_world_view.translation.cast<float>();
  const size_t first_pixel = cloud.positions.size();
  for (int v = 0; v < height; ++v) {
    for (int u = 0; u < width; ++u) {
      const cv::Vec4f& p = ray_points.at<cv::Vec4f>(v, u);
      const cv::Vec4f& n = ray_normals.at<cv::Vec4f>(v, u);
      colors_from_views.AddSample(R_world_view * Eigen::Vector3f(p[0], p[1], p[2]) + t_world_view,
                                  R_world_view * Eigen::Vector3f(n[0], n[1], n[2]));
    }
  }
  for (size_t i = 0; i < count; ++i) {
    KeyFrameView images = load(i, true);
    CheckImages(images, camera, i, true);
    ClipDepth(&images.depth, max_depth);
    colors_from_views.AddView(images.depth, images.color, T_world_cams[i], camera, truncation);
  }
  Eigen::Vector3f rgb;
  for (size_t i = 0; i < cloud.positions.size(); ++i) {
    if (colors_from_views.FacesAway(i)) {
      cloud.normals[i] = -cloud.normals[i];
      ++result.normals_flipped;
    }
    if (!colors_from_views.Get(i, &rgb)) {
      ++result.points_colored_by_volume;
      continue;
    }
    for (int k = 0; k < 3; ++k) cloud.colors[i][k] = cv::saturate_cast<uint8_t>(rgb[k]);
  }
  for (int v = 0; v < height; ++v) {
    for (int u = 0; u < width; ++u) {
      // A pixel keeps the volume's colour rather than one from behind it.
      const size_t sample = first_pixel + static_cast<size_t>(v) * width + u;
      if (!colors_from_views.FacesAway(sample) && colors_from_views.Get(sample, &rgb)) {
        ray_colors.at<cv::Vec4f>(v, u) = cv::Vec4f(rgb[0], rgb[1], rgb[2], 0);
      }
    }
  }
  model.rendering =
      Shade(ray_points, ray_normals, ray_colors, static_cast<float>(3 * truncation / 4));
  result.color_seconds = MillisecondsSince(start) / 1000.0;
  return model;
}

// ---------------------------------------------------------------------------
// The command

namespace {

// Outputs' folders first: a missing one should not wait for the fusion.
void CheckOutputFolders(const std::vector<fs::path>& outputs) {
  for (const fs::path& output : outputs) {
    const fs::path parent = fs::absolute(output).parent_path();
    std::error_code ec;
    if (!fs::is_directory(parent, ec)) {
      throw CantCreateError(output.string() + ": folder " + parent.string() + " does not exist");
    }
  }
}

// The PLY's header comments: what produced the points, from what, and how.
std::vector<std::string> CloudComments(const std::string& producer,
                                       const nlohmann::ordered_json& options_json,
                                       const std::string& map_name,
                                       const std::string& frame_comment,
                                       const DenseResult& result) {
  const Eigen::Vector3d& o = result.volume_origin;
  return {"producer " + producer,
          "rrslam-render dense: TSDF surface points (OpenCV rgbd COLOREDTSDF) of " + map_name,
          frame_comment,
          "options " + DumpJson(options_json),
          "volume voxel " + Format("%g", result.voxel) + " truncation " +
              Format("%g", result.truncation) + " origin " + Format("%.6f", o.x()) + " " +
              Format("%.6f", o.y()) + " " + Format("%.6f", o.z()) + " resolution " +
              std::to_string(result.resolution.x()) + " " + std::to_string(result.resolution.y()) +
              " " + std::to_string(result.resolution.z()),
          "keyframes_fused " + std::to_string(result.keyframes_fused),
          "normals_flipped " + std::to_string(result.normals_flipped)};
}

// The rendering's metadata: producer, description, options and viewpoint.
ImageMetadata RenderingMetadata(const std::string& producer,
                                const nlohmann::ordered_json& options_json,
                                const DenseOptions& options, const std::string& map_name,
                                const DenseResult& result) {
  const Eigen::Vector3d eye = result.T_world_view.translation;
  const Eigen::Vector3d forward = result.T_world_view.RotationMatrix().col(2);
  const nlohmann::ordered_json view_json = {
      {"position", {eye.x(), eye.y(), eye.z()}},
      {"forward", {forward.x(), forward.y(), forward.z()}},
      {"fx", result.view_fx},
      {"cx", result.view_cx},
      {"cy", result.view_cy},
      {"rule",
       "keyframes' mean viewing direction at the centre of the surface points, backed off until "
       "98% of them are in a 66-degree view, framed to their 1%..99% range"}};
  ImageMetadata metadata;
  metadata.software = producer;
  metadata.description = "Dense TSDF model of " + map_name + " (" +
                         std::to_string(result.keyframes_fused) + " keyframes of " +
                         options.sequence.string() + "), raycast and shaded";
  metadata.attributes = {{"rrslam:options", DumpJson(options_json)},
                         {"rrslam:view", DumpJson(view_json)}};
  return metadata;
}

// Outputs, each written atomically: the point cloud, then the rendering.
void WriteOutputs(const DenseOptions& options, const fs::path& image_path,
                  const std::string& map_name, const std::string& frame_comment,
                  DenseModel* model) {
  const auto start = SteadyClock::now();
  DenseResult& result = model->result;
  const std::string producer = Producer("render");
  const nlohmann::ordered_json options_json = options.ToJson();
  model->cloud.comments = CloudComments(producer, options_json, map_name, frame_comment, result);
  WritePly(options.out, model->cloud,
           options.binary ? PlyFormat::kBinaryLittleEndian : PlyFormat::kAscii);
  WritePicture(image_path, model->rendering,
               RenderingMetadata(producer, options_json, options, map_name, result));
  result.write_seconds = MillisecondsSince(start) / 1000.0;
}

// The summary on stdout: the model's size, the time of each step, the outputs.
void PrintSummary(const DenseResult& result, const DenseOptions& options,
                  const fs::path& image_path) {
  std::cout << "dense: " << result.keyframes_fused << " keyframes fused, " << result.points
            << " points; volume " << result.resolution.x() << " x " << result.resolution.y()
            << " x " << result.resolution.z() << " voxels of " << result.voxel << " m ("
            << Format("%.0f", result.volume_bytes / 1e6) << " MB); bounds "
            << Format("%.1f", result.bounds_seconds) << " s, fuse "
            << Format("%.1f", result.fuse_seconds) << " s, export "
            << Format("%.1f", result.export_seconds) << " s, colour "
            << Format("%.1f", result.color_seconds) << " s, write "
            << Format("%.1f", result.write_seconds) << " s\n"
            << "wrote " << options.out.string() << " and " << image_path.string() << "\n";
}

}  // namespace

DenseResult RunDense(const DenseOptions& options) {
  std::string why;
  if (!options.Check(&why)) throw UsageError(why);
  const fs::path image_path = options.ImagePath();
  CheckOutputFolders({options.out, image_path});

  const FramedMap framed =
      LoadMapInFrame(options.map, options.frame, options.sequence, options.associations);
  const MapScene& scene = framed.scene;
  const std::string map_name = options.map.string();
  CheckFusableMap(scene);
  const KeyFrameImages images(scene, options.sequence, options.associations);
  const KeyFrameCamera& camera = images.camera();
  const DenseImageLoader load = [&images](size_t index, bool with_color) {
    return images.Load(index, with_color);
  };
  spdlog::info("dense: fusing {} keyframes of {} ({}x{}{})", scene.keyframes.size(), map_name,
               camera.width, camera.height, images.undistorts() ? ", undistorted" : "");
  std::vector<Rigid3d> poses;
  poses.reserve(scene.keyframes.size());
  for (const SceneKeyFrame& keyframe : scene.keyframes) poses.push_back(keyframe.T_world_cam);
  DenseModel model = BuildDenseModel(options, camera, poses, load);

  WriteOutputs(options, image_path, map_name, framed.comment, &model);
  PrintSummary(model.result, options, image_path);
  return model.result;
}

}  // namespace rrslam
