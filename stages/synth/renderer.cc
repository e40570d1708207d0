#include "stages/synth/renderer.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <limits>
#include <opencv2/core.hpp>
#include <stdexcept>

namespace rrslam::synth {
namespace {

// A surface set up for one view. For the ray of pixel (u, v),
//   d(u, v) = ((u - cx) / fx, (v - cy) / fy, 1),
// the plane n_cam . p = h is met at depth z = h / den with
//   den = n_cam . d = alpha u + beta v + gamma,
// and the texture coordinates there are a = z * (la . (u, v, 1)) - a0 and
// b = z * (lb . (u, v, 1)) - b0.
struct FaceSetup {
  int surface_id = -1;
  double alpha = 0, beta = 0, gamma = 0, h = 0;
  double la[3] = {0, 0, 0}, a0 = 0;
  double lb[3] = {0, 0, 0}, b0 = 0;
  double size_a = 0, size_b = 0;
  int u0 = 0, u1 = -1, v0 = 0, v1 = -1;  // Inclusive pixel bounding box.
};

struct Hit {
  double z, a, b;
};

inline bool Intersect(const FaceSetup& f, double u, double v, Hit* hit) {
  const double den = f.alpha * u + f.beta * v + f.gamma;
  if (den >= -1e-15) return false;  // Parallel or behind.
  const double z = f.h / den;
  const double a = z * (f.la[0] * u + f.la[1] * v + f.la[2]) - f.a0;
  if (a < -kEdgeTolerance || a > f.size_a + kEdgeTolerance) return false;
  const double b = z * (f.lb[0] * u + f.lb[1] * v + f.lb[2]) - f.b0;
  if (b < -kEdgeTolerance || b > f.size_b + kEdgeTolerance) return false;
  *hit = {z, a, b};
  return true;
}

// Coefficients of the affine function w . (u, v, 1) = w_cam . d(u, v).
void RayCoefficients(const Eigen::Vector3d& w, const PinholeCamera& camera, double out[3]) {
  out[0] = w.x() / camera.fx();
  out[1] = w.y() / camera.fy();
  out[2] = w.z() - w.x() * camera.cx() / camera.fx() - w.y() * camera.cy() / camera.fy();
}

// The surfaces facing the camera, with their screen bounding boxes.
std::vector<FaceSetup> SetUpFaces(const Scene& scene, const PinholeCamera& camera,
                                  const Rigid3d& T_world_cam) {
  const Rigid3d T_cam_world = T_world_cam.Inverse();
  const Eigen::Matrix3d R_cam_world = T_cam_world.RotationMatrix();
  const Eigen::Vector3d& centre_world = T_world_cam.translation;
  const int width = camera.width(), height = camera.height();
  std::vector<FaceSetup> faces;
  for (const Surface& s : scene.surfaces()) {
    if (s.PlaneDistance(centre_world) <= 1e-9) continue;  // Back side or edge-on.
    const Eigen::Vector3d origin = T_cam_world * s.origin_world;
    const Eigen::Vector3d axis_a = R_cam_world * s.axis_a_world;
    const Eigen::Vector3d axis_b = R_cam_world * s.axis_b_world;
    const Eigen::Vector3d normal = R_cam_world * s.normal_world;

    // Clip the rectangle to the near plane (Sutherland-Hodgman on one plane).
    Eigen::Vector3d corners[4];
    for (int i = 0; i < 4; ++i) corners[i] = T_cam_world * s.Corner(i);
    std::vector<Eigen::Vector3d> clipped;
    for (int i = 0; i < 4; ++i) {
      const Eigen::Vector3d& p = corners[i];
      const Eigen::Vector3d& q = corners[(i + 1) % 4];
      const bool p_in = p.z() >= Renderer::kNearPlane, q_in = q.z() >= Renderer::kNearPlane;
      if (p_in) clipped.push_back(p);
      if (p_in != q_in) {
        const double t = (Renderer::kNearPlane - p.z()) / (q.z() - p.z());
        clipped.push_back(p + t * (q - p));
      }
    }
    if (clipped.empty()) continue;
    double u_min = std::numeric_limits<double>::infinity(), u_max = -u_min;
    double v_min = u_min, v_max = -u_min;
    for (const auto& p : clipped) {
      const Eigen::Vector2d uv = camera.Project(p);
      u_min = std::min(u_min, uv.x()), u_max = std::max(u_max, uv.x());
      v_min = std::min(v_min, uv.y()), v_max = std::max(v_max, uv.y());
    }
    // One pixel of margin: the exact inside test decides.
    FaceSetup f;
    f.u0 = static_cast<int>(std::max(0.0, std::ceil(u_min) - 1.0));
    f.u1 = static_cast<int>(std::min(width - 1.0, std::floor(u_max) + 1.0));
    f.v0 = static_cast<int>(std::max(0.0, std::ceil(v_min) - 1.0));
    f.v1 = static_cast<int>(std::min(height - 1.0, std::floor(v_max) + 1.0));
    if (f.u0 > f.u1 || f.v0 > f.v1) continue;
    f.surface_id = s.id;
    double n[3];
    RayCoefficients(normal, camera, n);
    f.alpha = n[0], f.beta = n[1], f.gamma = n[2];
    f.h = normal.dot(origin);
    RayCoefficients(axis_a, camera, f.la);
    f.a0 = axis_a.dot(origin);
    RayCoefficients(axis_b, camera, f.lb);
    f.b0 = axis_b.dot(origin);
    f.size_a = s.size_a;
    f.size_b = s.size_b;
    faces.push_back(f);
  }
  return faces;
}

// Shaded colour of face `f` seen through image point (u, v), its texture
// filtered over a footprint of `footprint` pixels.
Eigen::Vector3f Shade(const Scene& scene, const FaceSetup& f, double u, double v,
                      double footprint) {
  const double den = f.alpha * u + f.beta * v + f.gamma;
  const double z = f.h / den;
  const double la = f.la[0] * u + f.la[1] * v + f.la[2];
  const double lb = f.lb[0] * u + f.lb[1] * v + f.lb[2];
  const double a = z * la - f.a0, b = z * lb - f.b0;
  // Derivatives of z, a, b with respect to u and v.
  const double z_u = -z * f.alpha / den, z_v = -z * f.beta / den;
  const float da_du = static_cast<float>((z_u * la + z * f.la[0]) * footprint);
  const float da_dv = static_cast<float>((z_v * la + z * f.la[1]) * footprint);
  const float db_du = static_cast<float>((z_u * lb + z * f.lb[0]) * footprint);
  const float db_dv = static_cast<float>((z_v * lb + z * f.lb[1]) * footprint);
  const Surface& s = scene.surface(f.surface_id);
  const Eigen::Vector3d point_world = s.origin_world + a * s.axis_a_world + b * s.axis_b_world;
  return scene.Albedo(f.surface_id, static_cast<float>(a), static_cast<float>(b), da_du, db_du,
                      da_dv, db_dv) *
         scene.Shading(point_world, s.normal_world);
}

}  // namespace

Renderer::Renderer(const Scene& scene, const PinholeCamera& camera)
    : scene_(scene), camera_(camera) {
  if (!camera.distortion().IsZero() || camera.width() <= 0 || camera.height() <= 0) {
    throw std::invalid_argument("Renderer: the camera must have a size and no distortion");
  }
}

RenderedFrame Renderer::Render(const Rigid3d& T_world_cam) const {
  const int width = camera_.width(), height = camera_.height();
  const std::vector<FaceSetup> faces = SetUpFaces(scene_, camera_, T_world_cam);

  // Visibility at pixel centres: z-buffer over faces in scene order (strictly
  // nearer wins, so ties go to the earlier surface).
  std::vector<double> zbuffer(size_t(width) * height, std::numeric_limits<double>::infinity());
  std::vector<int> owner(size_t(width) * height, -1);  // Index into `faces`.
  for (size_t k = 0; k < faces.size(); ++k) {
    const FaceSetup& f = faces[k];
    for (int v = f.v0; v <= f.v1; ++v) {
      double* zrow = &zbuffer[size_t(v) * width];
      int* orow = &owner[size_t(v) * width];
      for (int u = f.u0; u <= f.u1; ++u) {
        Hit hit;
        if (Intersect(f, u, v, &hit) && hit.z < zrow[u]) {
          zrow[u] = hit.z;
          orow[u] = static_cast<int>(k);
        }
      }
    }
  }

  RenderedFrame frame;
  frame.color.create(height, width, CV_32FC3);
  frame.depth.create(height, width, CV_32FC1);
  frame.surface_id.create(height, width, CV_32SC1);
  frame.cos_incidence.create(height, width, CV_32FC1);
  constexpr int kS = kEdgeSamples;
  for (int v = 0; v < height; ++v) {
    float* color = frame.color.ptr<float>(v);
    float* depth = frame.depth.ptr<float>(v);
    int* ids = frame.surface_id.ptr<int>(v);
    float* cosine = frame.cos_incidence.ptr<float>(v);
    for (int u = 0; u < width; ++u) {
      const size_t index = size_t(v) * width + u;
      const int k = owner[index];
      if (k < 0) {
        color[3 * u] = color[3 * u + 1] = color[3 * u + 2] = 0.0f;
        depth[u] = 0.0f;
        ids[u] = -1;
        cosine[u] = 0.0f;
        continue;
      }
      const FaceSetup& f = faces[k];
      depth[u] = static_cast<float>(zbuffer[index]);
      ids[u] = f.surface_id;
      const double dx = (u - camera_.cx()) / camera_.fx(), dy = (v - camera_.cy()) / camera_.fy();
      cosine[u] = static_cast<float>(-(f.alpha * u + f.beta * v + f.gamma) /
                                     std::sqrt(dx * dx + dy * dy + 1.0));

      // Faces at the 3 x 3 neighbourhood's pixel centres; more than one means
      // the pixel straddles a boundary.
      int candidates[9];
      int num_candidates = 0;
      for (int dv = -1; dv <= 1; ++dv) {
        const int vv = v + dv;
        if (vv < 0 || vv >= height) continue;
        for (int du = -1; du <= 1; ++du) {
          const int uu = u + du;
          if (uu < 0 || uu >= width) continue;
          const int c = owner[size_t(vv) * width + uu];
          if (c < 0 || std::find(candidates, candidates + num_candidates, c) !=
                           candidates + num_candidates) {
            continue;
          }
          candidates[num_candidates++] = c;
        }
      }
      Eigen::Vector3f rgb;
      if (num_candidates == 1) {
        rgb = Shade(scene_, f, u, v, 1.0);
      } else {
        rgb.setZero();
        int samples = 0;
        for (int i = 0; i < kS; ++i) {
          for (int j = 0; j < kS; ++j) {
            const double su = u + (j + 0.5) / kS - 0.5, sv = v + (i + 0.5) / kS - 0.5;
            int best = -1;
            double best_z = std::numeric_limits<double>::infinity();
            for (int c = 0; c < num_candidates; ++c) {
              Hit hit;
              if (Intersect(faces[candidates[c]], su, sv, &hit) && hit.z < best_z) {
                best_z = hit.z;
                best = candidates[c];
              }
            }
            if (best < 0) {
              // A surface seen at no neighbouring centre (a sliver): search all.
              for (size_t c = 0; c < faces.size(); ++c) {
                Hit hit;
                if (Intersect(faces[c], su, sv, &hit) && hit.z < best_z) {
                  best_z = hit.z;
                  best = static_cast<int>(c);
                }
              }
            }
            if (best < 0) continue;
            rgb += Shade(scene_, faces[best], su, sv, 1.0 / kS);
            ++samples;
          }
        }
        if (samples > 0) rgb /= static_cast<float>(samples);
      }
      color[3 * u + 0] = rgb[0], color[3 * u + 1] = rgb[1], color[3 * u + 2] = rgb[2];
    }
  }
  return frame;
}

cv::Mat Renderer::RenderAveragedColor(const std::vector<Rigid3d>& poses) const {
  assert(!poses.empty());
  cv::Mat sum = Render(poses[0]).color;
  for (size_t i = 1; i < poses.size(); ++i) sum += Render(poses[i]).color;
  return sum / static_cast<double>(poses.size());
}

cv::Mat ToColor8(const cv::Mat& color, double gain) {
  assert(color.type() == CV_32FC3);
  cv::Mat out(color.rows, color.cols, CV_8UC3);
  const float g = static_cast<float>(gain);
  for (int r = 0; r < color.rows; ++r) {
    const float* s = color.ptr<float>(r);
    uint8_t* d = out.ptr<uint8_t>(r);
    for (int c = 0; c < 3 * color.cols; ++c) {
      const float x = s[c] * g + 0.5f;
      d[c] = static_cast<uint8_t>(x <= 0.0f ? 0.0f : (x >= 255.0f ? 255.0f : x));
    }
  }
  return out;
}

SimpleFrame RenderFrame(const Scene& scene, const PinholeCamera& camera,
                        const Rigid3d& T_world_cam) {
  const RenderedFrame frame = Renderer(scene, camera).Render(T_world_cam);
  return {ToColor8(frame.color), frame.depth};
}

}  // namespace rrslam::synth
