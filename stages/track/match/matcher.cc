#include "stages/track/match/matcher.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace rrslam {
namespace {

// A keypoint already matched to a map point (one that keyframes observe) is
// not a candidate of the projection searches. One matched to a temporary
// point (localization mode's visual-odometry points, which no keyframe
// observes) still is, and a map point found there replaces it (ORB-SLAM2's
// `Observations() > 0` test).
bool MatchedToMapPoint(const MapPoint* point) {
  return point != nullptr && point->num_observations() > 0;
}

// Visits the pairs of (node, indices) entries of two feature vectors that
// share a node, in node order.
template <typename Fn>
void ForEachSharedNode(const FeatureVector& a, const FeatureVector& b, Fn fn) {
  auto ia = a.entries.begin();
  auto ib = b.entries.begin();
  while (ia != a.entries.end() && ib != b.entries.end()) {
    if (ia->first == ib->first) {
      fn(ia->second, ib->second);
      ++ia;
      ++ib;
    } else if (ia->first < ib->first) {
      ia = std::lower_bound(ia, a.entries.end(), ib->first,
                            [](const auto& e, NodeId n) { return e.first < n; });
    } else {
      ib = std::lower_bound(ib, b.entries.end(), ia->first,
                            [](const auto& e, NodeId n) { return e.first < n; });
    }
  }
}

// Squared distance of x2 to the epipolar line of x1 (ideal pixels) is below
// the 95% chi-square bound of one degree of freedom at x2's level.
bool NearEpipolarLine(const Eigen::Vector2f& x1, const Eigen::Vector2f& x2,
                      const Eigen::Matrix3d& F12, double sigma2) {
  const double a = x1.x() * F12(0, 0) + x1.y() * F12(1, 0) + F12(2, 0);
  const double b = x1.x() * F12(0, 1) + x1.y() * F12(1, 1) + F12(2, 1);
  const double c = x1.x() * F12(0, 2) + x1.y() * F12(1, 2) + F12(2, 2);
  const double num = a * x2.x() + b * x2.y() + c;
  const double den = a * a + b * b;
  if (den == 0) return false;
  return num * num / den < 3.84 * sigma2;
}

}  // namespace

int RotationHistogram::Bin(float rotation_deg) {
  float rot = rotation_deg;
  while (rot < 0) rot += 360.0f;
  while (rot >= 360.0f) rot -= 360.0f;
  // ORB-SLAM2: round(rot * factor) with factor = 1 / HISTO_LENGTH, in float.
  const int bin = static_cast<int>(std::round(rot * (1.0f / 30.0f)));
  return std::min(bin, kBins - 1);
}

void RotationHistogram::Add(float angle1_deg, float angle2_deg, int item) {
  bins_[Bin(angle1_deg - angle2_deg)].push_back(item);
}

std::vector<int> RotationHistogram::Inconsistent() const {
  size_t max1 = 0, max2 = 0, max3 = 0;
  int ind1 = -1, ind2 = -1, ind3 = -1;
  for (int i = 0; i < kBins; ++i) {
    const size_t s = bins_[i].size();
    if (s > max1) {
      max3 = max2;
      max2 = max1;
      max1 = s;
      ind3 = ind2;
      ind2 = ind1;
      ind1 = i;
    } else if (s > max2) {
      max3 = max2;
      max2 = s;
      ind3 = ind2;
      ind2 = i;
    } else if (s > max3) {
      max3 = s;
      ind3 = i;
    }
  }
  if (max2 < 0.1 * max1) {
    ind2 = -1;
    ind3 = -1;
  } else if (max3 < 0.1 * max1) {
    ind3 = -1;
  }
  std::vector<int> out;
  for (int i = 0; i < kBins; ++i) {
    if (i == ind1 || i == ind2 || i == ind3) continue;
    out.insert(out.end(), bins_[i].begin(), bins_[i].end());
  }
  return out;
}

bool ProjectIntoView(const SensorModel& sensor, const Eigen::Matrix3d& R_cam_world,
                     const Eigen::Vector3d& t_cam_world, const Eigen::Vector3d& centre,
                     MapPoint* point, double min_view_cos, ProjectedPoint* out) {
  const Eigen::Vector3d& p_world = point->position_world();
  const Eigen::Vector3d p_cam = R_cam_world * p_world + t_cam_world;
  if (p_cam.z() <= 0) return false;
  const double inv_z = 1.0 / p_cam.z();
  const double u = sensor.fx * p_cam.x() * inv_z + sensor.cx;
  const double v = sensor.fy * p_cam.y() * inv_z + sensor.cy;
  if (!sensor.bounds.Contains(u, v)) return false;
  const Eigen::Vector3d ray = p_world - centre;
  const double distance = ray.norm();
  if (distance < point->MinDistanceInvariance() || distance > point->MaxDistanceInvariance()) {
    return false;
  }
  const double view_cos = ray.dot(point->normal()) / distance;
  if (view_cos < min_view_cos) return false;
  out->point = point;
  out->u = u;
  out->v = v;
  out->u_right = u - sensor.bf * inv_z;
  out->level = point->PredictScale(sensor, distance);
  out->view_cos = view_cos;
  return true;
}

Eigen::Matrix3d FundamentalMatrix(const SensorModel& sensor, const KeyFrame& kf1,
                                  const KeyFrame& kf2) {
  // X1 = R12 X2 + t12 for camera-frame points; E12 = [t12]x R12.
  const Eigen::Matrix3d R1w = kf1.R_cam_world();
  const Eigen::Matrix3d R2w = kf2.R_cam_world();
  const Eigen::Matrix3d R12 = R1w * R2w.transpose();
  const Eigen::Vector3d t12 = -R12 * kf2.T_cam_world().translation + kf1.T_cam_world().translation;
  const Eigen::Matrix3d K = sensor.camera.K();
  const Eigen::Matrix3d K_inv = K.inverse();
  return K_inv.transpose() * Skew(t12) * R12 * K_inv;
}

int Matcher::SearchByProjection(Frame* current, const Frame& last, double th) const {
  const FrameFeatures& cf = current->features();
  const FrameFeatures& lf = last.features();
  const ScalePyramid& pyramid = sensor_.pyramid;
  // Current camera centre in the last camera's frame tells forward/backward
  // motion: moving forward, points appear at coarser levels, and vice versa.
  const Eigen::Vector3d t_last_current = last.ToCamera(current->camera_centre());
  const bool forward = t_last_current.z() > sensor_.baseline;
  const bool backward = -t_last_current.z() > sensor_.baseline;

  RotationHistogram histogram;
  std::vector<uint32_t> candidates;
  int matches = 0;
  for (size_t i = 0; i < last.size(); ++i) {
    MapPoint* point = last.map_points[i];
    if (point == nullptr || last.outlier[i] || point->bad()) continue;
    const Eigen::Vector3d p_cam = current->ToCamera(point->position_world());
    if (p_cam.z() <= 0) continue;
    const double inv_z = 1.0 / p_cam.z();
    const double u = sensor_.fx * p_cam.x() * inv_z + sensor_.cx;
    const double v = sensor_.fy * p_cam.y() * inv_z + sensor_.cy;
    if (!sensor_.bounds.Contains(u, v)) continue;

    const int last_octave = lf.Octave(i);
    const double radius = th * pyramid.scale[last_octave];
    candidates.clear();
    if (forward) {
      cf.FeaturesInArea(sensor_, u, v, radius, last_octave, -1, &candidates);
    } else if (backward) {
      cf.FeaturesInArea(sensor_, u, v, radius, 0, last_octave, &candidates);
    } else {
      cf.FeaturesInArea(sensor_, u, v, radius, last_octave - 1, last_octave + 1, &candidates);
    }
    if (candidates.empty()) continue;

    const double u_right = u - sensor_.bf * inv_z;
    const OrbDescriptor& descriptor = point->descriptor();
    int best_dist = 256;
    int best_idx = -1;
    for (uint32_t idx : candidates) {
      if (MatchedToMapPoint(current->map_points[idx])) continue;
      if (cf.HasDepth(idx) && std::abs(u_right - cf.u_right[idx]) > radius) continue;
      const int dist = HammingDistance(descriptor, cf.descriptors[idx]);
      if (dist < best_dist) {
        best_dist = dist;
        best_idx = static_cast<int>(idx);
      }
    }
    if (best_dist <= kHammingHigh) {
      current->map_points[best_idx] = point;
      ++matches;
      if (check_orientation_) {
        histogram.Add(lf.keypoints[i].angle_deg, cf.keypoints[best_idx].angle_deg, best_idx);
      }
    }
  }
  if (check_orientation_) {
    for (int idx : histogram.Inconsistent()) {
      current->map_points[idx] = nullptr;
      --matches;
    }
  }
  return matches;
}

double LocalMapSearchRadius(const ProjectedPoint& pp, double th, const ScalePyramid& pyramid) {
  return (pp.view_cos > 0.998 ? 2.5 : 4.0) * th * pyramid.scale[pp.level];
}

int Matcher::SearchByProjection(Frame* frame, const std::vector<ProjectedPoint>& points,
                                double th) const {
  const FrameFeatures& f = frame->features();
  const ScalePyramid& pyramid = sensor_.pyramid;
  std::vector<uint32_t> candidates;
  int matches = 0;
  for (const ProjectedPoint& pp : points) {
    MapPoint* point = pp.point;
    if (point->bad()) continue;
    const double r = LocalMapSearchRadius(pp, th, pyramid);
    candidates.clear();
    f.FeaturesInArea(sensor_, pp.u, pp.v, r, pp.level - 1, pp.level, &candidates);
    if (candidates.empty()) continue;

    const OrbDescriptor& descriptor = point->descriptor();
    int best_dist = 256, best_dist2 = 256;
    int best_level = -1, best_level2 = -1;
    int best_idx = -1;
    for (uint32_t idx : candidates) {
      if (MatchedToMapPoint(frame->map_points[idx])) continue;
      if (f.HasDepth(idx) && std::abs(pp.u_right - f.u_right[idx]) > r) continue;
      const int dist = HammingDistance(descriptor, f.descriptors[idx]);
      if (dist < best_dist) {
        best_dist2 = best_dist;
        best_level2 = best_level;
        best_dist = dist;
        best_level = f.Octave(idx);
        best_idx = static_cast<int>(idx);
      } else if (dist < best_dist2) {
        best_dist2 = dist;
        best_level2 = f.Octave(idx);
      }
    }
    if (best_dist > kHammingHigh) continue;
    // The ratio test applies only between candidates of the same level.
    if (best_level == best_level2 && best_dist > nn_ratio_ * best_dist2) continue;
    frame->map_points[best_idx] = point;
    ++matches;
  }
  return matches;
}

int Matcher::SearchByProjection(Frame* frame, const KeyFrame& keyframe,
                                const std::vector<MapPointId>& already_found, double th,
                                int max_distance) const {
  const FrameFeatures& f = frame->features();
  const FrameFeatures& kf = keyframe.features();
  RotationHistogram histogram;
  std::vector<uint32_t> candidates;
  int matches = 0;
  for (size_t i = 0; i < keyframe.size(); ++i) {
    MapPoint* point = keyframe.map_point(i);
    if (point == nullptr || point->bad() ||
        std::binary_search(already_found.begin(), already_found.end(), point->id())) {
      continue;
    }
    // No viewing-angle test here (ORB-SLAM2's relocalization search has none).
    ProjectedPoint pp;
    if (!ProjectIntoView(sensor_, frame->R_cam_world(), frame->T_cam_world().translation,
                         frame->camera_centre(), point, -1.0, &pp)) {
      continue;
    }
    const int level = pp.level;
    candidates.clear();
    f.FeaturesInArea(sensor_, pp.u, pp.v, th * sensor_.pyramid.scale[level], level - 1, level + 1,
                     &candidates);
    int best_dist = 256, best_idx = -1;
    for (uint32_t idx : candidates) {
      if (frame->map_points[idx] != nullptr) continue;
      const int dist = HammingDistance(point->descriptor(), f.descriptors[idx]);
      if (dist < best_dist) {
        best_dist = dist;
        best_idx = static_cast<int>(idx);
      }
    }
    if (best_idx < 0 || best_dist > max_distance) continue;
    frame->map_points[best_idx] = point;
    ++matches;
    if (check_orientation_) {
      histogram.Add(kf.keypoints[i].angle_deg, f.keypoints[best_idx].angle_deg, best_idx);
    }
  }
  if (check_orientation_) {
    for (int idx : histogram.Inconsistent()) {
      frame->map_points[idx] = nullptr;
      --matches;
    }
  }
  return matches;
}

int Matcher::SearchByBow(const KeyFrame& keyframe, const Frame& frame,
                         std::vector<MapPoint*>* matches) const {
  const FrameFeatures& kf = keyframe.features();
  const FrameFeatures& ff = frame.features();
  matches->assign(frame.size(), nullptr);
  RotationHistogram histogram;
  int n = 0;
  ForEachSharedNode(
      keyframe.feature_vector(), frame.feature_vector(),
      [&](const std::vector<uint32_t>& kf_indices, const std::vector<uint32_t>& f_indices) {
        for (uint32_t idx_kf : kf_indices) {
          MapPoint* point = keyframe.map_point(idx_kf);
          if (point == nullptr || point->bad()) continue;
          const OrbDescriptor& d = kf.descriptors[idx_kf];
          int best_dist1 = 256, best_dist2 = 256, best_idx = -1;
          for (uint32_t idx_f : f_indices) {
            if ((*matches)[idx_f] != nullptr) continue;
            const int dist = HammingDistance(d, ff.descriptors[idx_f]);
            if (dist < best_dist1) {
              best_dist2 = best_dist1;
              best_dist1 = dist;
              best_idx = static_cast<int>(idx_f);
            } else if (dist < best_dist2) {
              best_dist2 = dist;
            }
          }
          if (best_dist1 <= kHammingLow && best_dist1 < nn_ratio_ * best_dist2) {
            (*matches)[best_idx] = point;
            ++n;
            if (check_orientation_) {
              histogram.Add(kf.keypoints[idx_kf].angle_deg, ff.keypoints[best_idx].angle_deg,
                            best_idx);
            }
          }
        }
      });
  if (check_orientation_) {
    for (int idx : histogram.Inconsistent()) {
      (*matches)[idx] = nullptr;
      --n;
    }
  }
  return n;
}

int Matcher::SearchForTriangulation(const KeyFrame& kf1, const KeyFrame& kf2,
                                    const Eigen::Matrix3d& F12, bool only_with_depth,
                                    std::vector<std::pair<uint32_t, uint32_t>>* pairs) const {
  const FrameFeatures& f1 = kf1.features();
  const FrameFeatures& f2 = kf2.features();
  const ScalePyramid& pyramid = sensor_.pyramid;
  // Epipole: camera centre 1 in image 2.
  const Eigen::Vector3d c2 = kf2.ToCamera(kf1.camera_centre());
  const double ex = sensor_.fx * c2.x() / c2.z() + sensor_.cx;
  const double ey = sensor_.fy * c2.y() / c2.z() + sensor_.cy;

  std::vector<uint8_t> matched2(f2.size(), 0);
  std::vector<int> match12(f1.size(), -1);
  RotationHistogram histogram;
  ForEachSharedNode(
      kf1.feature_vector(), kf2.feature_vector(),
      [&](const std::vector<uint32_t>& indices1, const std::vector<uint32_t>& indices2) {
        for (uint32_t idx1 : indices1) {
          if (kf1.map_point(idx1) != nullptr) continue;
          const bool depth1 = f1.HasDepth(idx1);
          if (only_with_depth && !depth1) continue;
          const Keypoint& kp1 = f1.keypoints[idx1];
          const OrbDescriptor& d1 = f1.descriptors[idx1];
          int best_dist = kHammingLow;
          int best_idx2 = -1;
          for (uint32_t idx2 : indices2) {
            if (matched2[idx2] || kf2.map_point(idx2) != nullptr) continue;
            const bool depth2 = f2.HasDepth(idx2);
            if (only_with_depth && !depth2) continue;
            const int dist = HammingDistance(d1, f2.descriptors[idx2]);
            if (dist > kHammingLow || dist > best_dist) continue;
            const Keypoint& kp2 = f2.keypoints[idx2];
            if (!depth1 && !depth2) {
              // Near the epipole, the epipolar constraint says nothing.
              const double dex = ex - kp2.undistorted.x();
              const double dey = ey - kp2.undistorted.y();
              if (dex * dex + dey * dey < 100.0 * pyramid.scale[kp2.octave]) continue;
            }
            if (NearEpipolarLine(kp1.undistorted.vec(), kp2.undistorted.vec(), F12,
                                 pyramid.sigma2[kp2.octave])) {
              best_idx2 = static_cast<int>(idx2);
              best_dist = dist;
            }
          }
          if (best_idx2 >= 0) {
            match12[idx1] = best_idx2;
            matched2[best_idx2] = 1;
            if (check_orientation_) {
              histogram.Add(kp1.angle_deg, f2.keypoints[best_idx2].angle_deg,
                            static_cast<int>(idx1));
            }
          }
        }
      });
  if (check_orientation_) {
    for (int idx1 : histogram.Inconsistent()) match12[idx1] = -1;
  }
  pairs->clear();
  for (size_t i = 0; i < match12.size(); ++i) {
    if (match12[i] >= 0) pairs->emplace_back(static_cast<uint32_t>(i), match12[i]);
  }
  return static_cast<int>(pairs->size());
}

int Matcher::Fuse(KeyFrame* keyframe, const std::vector<MapPoint*>& points, Map* map,
                  double th) const {
  const FrameFeatures& f = keyframe->features();
  const ScalePyramid& pyramid = sensor_.pyramid;
  const Eigen::Vector3d& centre = keyframe->camera_centre();
  std::vector<uint32_t> candidates;
  int fused = 0;
  for (MapPoint* point : points) {
    if (point == nullptr || point->bad() || point->IsObservedBy(keyframe)) continue;
    const Eigen::Vector3d& p_world = point->position_world();
    const Eigen::Vector3d p_cam = keyframe->ToCamera(p_world);
    if (p_cam.z() <= 0) continue;
    const double inv_z = 1.0 / p_cam.z();
    const double u = sensor_.fx * p_cam.x() * inv_z + sensor_.cx;
    const double v = sensor_.fy * p_cam.y() * inv_z + sensor_.cy;
    if (!sensor_.bounds.Contains(u, v)) continue;
    const double u_right = u - sensor_.bf * inv_z;
    const Eigen::Vector3d ray = p_world - centre;
    const double distance = ray.norm();
    if (distance < point->MinDistanceInvariance() || distance > point->MaxDistanceInvariance()) {
      continue;
    }
    if (ray.dot(point->normal()) < 0.5 * distance) continue;  // Viewing angle over 60 degrees.
    const int level = point->PredictScale(sensor_, distance);
    const double radius = th * pyramid.scale[level];
    candidates.clear();
    f.FeaturesInArea(sensor_, u, v, radius, -1, -1, &candidates);
    if (candidates.empty()) continue;

    const OrbDescriptor& descriptor = point->descriptor();
    int best_dist = 256;
    int best_idx = -1;
    for (uint32_t idx : candidates) {
      const Keypoint& kp = f.keypoints[idx];
      if (kp.octave < level - 1 || kp.octave > level) continue;
      const double ex = u - kp.undistorted.x();
      const double ey = v - kp.undistorted.y();
      if (f.HasDepth(idx)) {
        const double er = u_right - f.u_right[idx];
        if (sensor_.StereoChi2(ex, ey, er, kp.octave) > 7.8) continue;
      } else {
        if ((ex * ex + ey * ey) * pyramid.inv_sigma2[kp.octave] > 5.99) continue;
      }
      const int dist = HammingDistance(descriptor, f.descriptors[idx]);
      if (dist < best_dist) {
        best_dist = dist;
        best_idx = static_cast<int>(idx);
      }
    }
    if (best_dist > kHammingLow) continue;
    MapPoint* existing = keyframe->map_point(best_idx);
    if (existing != nullptr) {
      if (!existing->bad()) {
        if (existing->num_observations() > point->num_observations()) {
          map->ReplaceMapPoint(point, existing);
        } else {
          map->ReplaceMapPoint(existing, point);
        }
      }
    } else {
      map->AddObservation(point, keyframe, static_cast<uint32_t>(best_idx));
    }
    ++fused;
  }
  return fused;
}

int Matcher::SearchByBow(const KeyFrame& kf1, const KeyFrame& kf2,
                         std::vector<MapPoint*>* matches12) const {
  const FrameFeatures& f1 = kf1.features();
  const FrameFeatures& f2 = kf2.features();
  matches12->assign(kf1.size(), nullptr);
  std::vector<uint8_t> matched2(kf2.size(), 0);
  RotationHistogram histogram;
  int n = 0;
  ForEachSharedNode(
      kf1.feature_vector(), kf2.feature_vector(),
      [&](const std::vector<uint32_t>& indices1, const std::vector<uint32_t>& indices2) {
        for (uint32_t idx1 : indices1) {
          const MapPoint* point1 = kf1.map_point(idx1);
          if (point1 == nullptr || point1->bad()) continue;
          const OrbDescriptor& d = f1.descriptors[idx1];
          int best_dist1 = 256, best_dist2 = 256, best_idx = -1;
          for (uint32_t idx2 : indices2) {
            const MapPoint* point2 = kf2.map_point(idx2);
            if (matched2[idx2] || point2 == nullptr || point2->bad()) continue;
            const int dist = HammingDistance(d, f2.descriptors[idx2]);
            if (dist < best_dist1) {
              best_dist2 = best_dist1;
              best_dist1 = dist;
              best_idx = static_cast<int>(idx2);
            } else if (dist < best_dist2) {
              best_dist2 = dist;
            }
          }
          // ORB-SLAM2's keyframe-to-keyframe search: strictly below TH_LOW.
          if (best_idx < 0 || best_dist1 >= kHammingLow || !(best_dist1 < nn_ratio_ * best_dist2)) {
            continue;
          }
          (*matches12)[idx1] = kf2.map_point(best_idx);
          matched2[best_idx] = 1;
          ++n;
          if (check_orientation_) {
            histogram.Add(f1.keypoints[idx1].angle_deg, f2.keypoints[best_idx].angle_deg,
                          static_cast<int>(idx1));
          }
        }
      });
  if (check_orientation_) {
    for (int idx : histogram.Inconsistent()) {
      (*matches12)[idx] = nullptr;
      --n;
    }
  }
  return n;
}

namespace {

// Nearest keypoint of `keyframe` (distance <= max_distance) to `point` seen
// at camera coordinates `p_cam`, within th * scale of the predicted level,
// among levels predicted - 1 .. predicted; -1 when none. Checks the image
// bounds and the point's scale-invariance distances.
int NearestInView(const SensorModel& sensor, const KeyFrame& keyframe, const MapPoint& point,
                  const Eigen::Vector3d& p_cam, double th, int max_distance,
                  const std::vector<MapPoint*>* skip_matched, std::vector<uint32_t>* candidates) {
  if (p_cam.z() <= 0) return -1;
  const double inv_z = 1.0 / p_cam.z();
  const double u = sensor.fx * p_cam.x() * inv_z + sensor.cx;
  const double v = sensor.fy * p_cam.y() * inv_z + sensor.cy;
  if (!sensor.bounds.Contains(u, v)) return -1;
  const double distance = p_cam.norm();
  if (distance < point.MinDistanceInvariance() || distance > point.MaxDistanceInvariance()) {
    return -1;
  }
  const int level = point.PredictScale(sensor, distance);
  const FrameFeatures& f = keyframe.features();
  candidates->clear();
  f.FeaturesInArea(sensor, u, v, th * sensor.pyramid.scale[level], -1, -1, candidates);
  int best_dist = 256, best_idx = -1;
  for (uint32_t idx : *candidates) {
    const int octave = f.keypoints[idx].octave;
    if (octave < level - 1 || octave > level) continue;
    if (skip_matched != nullptr && (*skip_matched)[idx] != nullptr) continue;
    const int dist = HammingDistance(point.descriptor(), f.descriptors[idx]);
    if (dist < best_dist) {
      best_dist = dist;
      best_idx = static_cast<int>(idx);
    }
  }
  return best_dist <= max_distance ? best_idx : -1;
}

}  // namespace

int Matcher::SearchByRelativePose(const KeyFrame& kf1, const KeyFrame& kf2, const Rigid3d& T_12,
                                  double th, std::vector<MapPoint*>* matches12) const {
  const Rigid3d T_21 = T_12.Inverse();
  std::vector<uint8_t> already1(kf1.size(), 0), already2(kf2.size(), 0);
  for (size_t i = 0; i < kf1.size(); ++i) {
    MapPoint* point = (*matches12)[i];
    if (point == nullptr) continue;
    already1[i] = 1;
    const int i2 = point->IndexIn(&kf2);
    if (i2 >= 0) already2[i2] = 1;
  }
  std::vector<uint32_t> candidates;
  // kf1's points into kf2.
  std::vector<int> match1(kf1.size(), -1);
  for (size_t i = 0; i < kf1.size(); ++i) {
    const MapPoint* point = kf1.map_point(i);
    if (point == nullptr || point->bad() || already1[i]) continue;
    const Eigen::Vector3d p_c2 = T_21 * kf1.ToCamera(point->position_world());
    match1[i] = NearestInView(sensor_, kf2, *point, p_c2, th, kHammingHigh, nullptr, &candidates);
  }
  // kf2's points into kf1.
  std::vector<int> match2(kf2.size(), -1);
  for (size_t i = 0; i < kf2.size(); ++i) {
    const MapPoint* point = kf2.map_point(i);
    if (point == nullptr || point->bad() || already2[i]) continue;
    const Eigen::Vector3d p_c1 = T_12 * kf2.ToCamera(point->position_world());
    match2[i] = NearestInView(sensor_, kf1, *point, p_c1, th, kHammingHigh, nullptr, &candidates);
  }
  int found = 0;
  for (size_t i1 = 0; i1 < kf1.size(); ++i1) {
    const int i2 = match1[i1];
    if (i2 < 0 || match2[i2] != static_cast<int>(i1)) continue;
    (*matches12)[i1] = kf2.map_point(i2);
    ++found;
  }
  return found;
}

int Matcher::SearchByProjection(const KeyFrame& keyframe, const Rigid3d& T_cam_world,
                                const std::vector<MapPoint*>& points, double th,
                                std::vector<MapPoint*>* matched) const {
  std::vector<MapPointId> already;
  for (const MapPoint* point : *matched) {
    if (point != nullptr) already.push_back(point->id());
  }
  std::sort(already.begin(), already.end());
  const Eigen::Vector3d centre = T_cam_world.Inverse().translation;
  std::vector<uint32_t> candidates;
  int found = 0;
  for (MapPoint* point : points) {
    if (point == nullptr || point->bad() ||
        std::binary_search(already.begin(), already.end(), point->id())) {
      continue;
    }
    const Eigen::Vector3d ray = point->position_world() - centre;
    if (ray.dot(point->normal()) < 0.5 * ray.norm()) continue;  // Over 60 degrees.
    const int idx = NearestInView(sensor_, keyframe, *point, T_cam_world * point->position_world(),
                                  th, kHammingLow, matched, &candidates);
    if (idx < 0) continue;
    (*matched)[idx] = point;
    ++found;
  }
  return found;
}

int Matcher::FuseForLoop(KeyFrame* keyframe, const std::vector<MapPoint*>& points, Map* map,
                         double th, std::vector<MapPoint*>* replace) const {
  replace->assign(points.size(), nullptr);
  const Eigen::Vector3d& centre = keyframe->camera_centre();
  std::vector<uint32_t> candidates;
  int fused = 0;
  for (size_t p = 0; p < points.size(); ++p) {
    MapPoint* point = points[p];
    if (point == nullptr || point->bad() || point->IsObservedBy(keyframe)) continue;
    const Eigen::Vector3d ray = point->position_world() - centre;
    if (ray.dot(point->normal()) < 0.5 * ray.norm()) continue;  // Over 60 degrees.
    const int idx =
        NearestInView(sensor_, *keyframe, *point, keyframe->ToCamera(point->position_world()), th,
                      kHammingLow, nullptr, &candidates);
    if (idx < 0) continue;
    MapPoint* existing = keyframe->map_point(idx);
    if (existing != nullptr) {
      if (!existing->bad()) (*replace)[p] = existing;
    } else {
      map->AddObservation(point, keyframe, static_cast<uint32_t>(idx));
    }
    ++fused;
  }
  return fused;
}

}  // namespace rrslam
