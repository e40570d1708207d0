// Descriptor matching between frames, keyframes and map points, with the
// semantics of ORB-SLAM2's ORBmatcher (written anew):
//  - projection search: map points projected with a pose prediction, matched
//    to keypoints in a window around the projection at the predicted scale;
//  - BoW search: keypoints sharing a vocabulary node (FeatureVector) are the
//    only candidates, with Lowe's ratio test;
//  - rotation consistency: the orientation change of the matches is binned in
//    a histogram of 30-degree bins and matches outside the three fullest bins
//    are dropped (RotationHistogram: what ORB-SLAM2's code does, not what its
//    HISTO_LENGTH = 30 suggests);
//  - Hamming thresholds kHammingHigh (100) and kHammingLow (50).
// All matches are deterministic: candidates are visited in keypoint/node/id order.
// Thread-safety: const methods; the map objects touched must be locked by the
// caller (Map::mutex()).
#pragma once

#include <Eigen/Core>
#include <array>
#include <utility>
#include <vector>

#include "stages/track/data/frame.h"
#include "stages/track/data/keyframe.h"
#include "stages/track/data/map.h"
#include "stages/track/data/sensor_model.h"

namespace rrslam {

inline constexpr int kHammingHigh = 100;  // ORB-SLAM2's TH_HIGH.
inline constexpr int kHammingLow = 50;    // ORB-SLAM2's TH_LOW.

// Histogram of the orientation change (degrees) of candidate matches, binned
// exactly as ORB-SLAM2's ORBmatcher does it. ORB-SLAM2 declares HISTO_LENGTH =
// 30 bins but computes the bin as round(rotation * factor) with factor =
// 1 / HISTO_LENGTH, i.e. round(rotation / 30 deg): only 13 bins are used,
// 30 degrees wide and centred on multiples of 30 degrees, with bin 0 holding
// [0, 15) and bin 12 holding [345, 360) (a change near zero falls in one of
// two bins). Wide bins keep true matches whose orientations are noisy (motion
// blur); the three-maxima rule then keeps at most three of them.
class RotationHistogram {
 public:
  static constexpr int kBins = 13;  // round([0, 360) / 30) = 0 .. 12.

  // Records match `item` whose keypoints have orientations `angle1_deg` and
  // `angle2_deg` (change = angle1 - angle2 modulo 360).
  void Add(float angle1_deg, float angle2_deg, int item);
  // The items outside the three fullest bins, in insertion order per bin.
  // The second and third bins are kept only when they hold at least a tenth
  // of the fullest (ORB-SLAM2's ComputeThreeMaxima).
  std::vector<int> Inconsistent() const;
  // Bin of an orientation change in degrees.
  static int Bin(float rotation_deg);

 private:
  std::array<std::vector<int>, kBins> bins_;
};

// A map point predicted in a frame's view (ORB-SLAM2's isInFrustum results).
struct ProjectedPoint {
  MapPoint* point = nullptr;
  double u = 0, v = 0;  // Ideal pixel.
  double u_right = 0;   // Virtual right coordinate u - bf / z.
  int level = 0;        // Predicted pyramid level.
  double view_cos = 0;  // Cosine between viewing ray and the point's normal.
};

// The local-map search window's radius (pixels) round a projected point,
// `th` x its predicted level's scale x 2.5 when seen head-on (view cosine
// > 0.998), x 4 when seen obliquely, whose projection is less sure
// (ORB-SLAM2's RadiusByViewingCos).
double LocalMapSearchRadius(const ProjectedPoint& pp, double th, const ScalePyramid& pyramid);

// Projects `point` into a frame with pose (`R_cam_world`, `t_cam_world`,
// camera centre `centre`). True when it lies in front of the camera, inside
// the image bounds, within its scale-invariance distances, and is seen at an
// angle whose cosine with its normal is at least `min_view_cos`.
bool ProjectIntoView(const SensorModel& sensor, const Eigen::Matrix3d& R_cam_world,
                     const Eigen::Vector3d& t_cam_world, const Eigen::Vector3d& centre,
                     MapPoint* point, double min_view_cos, ProjectedPoint* out);

// Fundamental matrix F12 with x1^T F12 x2 = 0 for ideal pixels x1 in
// keyframe 1 and x2 in keyframe 2.
Eigen::Matrix3d FundamentalMatrix(const SensorModel& sensor, const KeyFrame& kf1,
                                  const KeyFrame& kf2);

class Matcher {
 public:
  // `nn_ratio`: Lowe's ratio (best < nn_ratio * second best) where a search
  // applies it; `check_orientation`: apply the rotation histogram.
  Matcher(const SensorModel& sensor, double nn_ratio, bool check_orientation)
      : sensor_(sensor), nn_ratio_(nn_ratio), check_orientation_(check_orientation) {}

  // Motion-model search: projects the last frame's inlier map points with
  // current->T_cam_world() and matches each in a window of th * scale of its
  // keypoint's level; with depth, the virtual right coordinate must agree
  // within the same radius, and the levels searched follow the camera's
  // forward/backward motion. Fills current->map_points where still empty or
  // holding a temporary point (one no keyframe observes: localization mode's
  // visual-odometry points), as ORB-SLAM2. Returns the number of new matches
  // (a keypoint matched twice counts twice, as in ORB-SLAM2).
  int SearchByProjection(Frame* current, const Frame& last, double th) const;

  // Local-map search: matches predicted points (ProjectIntoView) in a window of
  // th * (2.5 px when seen head-on, else 4 px) * scale of the predicted level,
  // on the predicted level and the one below, with the ratio test when the
  // two best candidates share a level. Keypoints matched to a temporary point
  // are candidates too (the map point replaces it). Returns the number of new
  // matches.
  int SearchByProjection(Frame* frame, const std::vector<ProjectedPoint>& points, double th) const;

  // Relocalization search: projects `keyframe`'s map points that are not in
  // `already_found` (sorted by id) with frame->T_cam_world() and matches each
  // to the nearest-descriptor keypoint without a map point within th * scale
  // of its predicted level (levels predicted - 1 .. + 1), if the distance is
  // at most `max_distance` (ORB-SLAM2's SearchByProjection(Frame, KeyFrame,
  // ...)), with the rotation histogram when enabled. Returns the number of
  // new matches.
  int SearchByProjection(Frame* frame, const KeyFrame& keyframe,
                         const std::vector<MapPointId>& already_found, double th,
                         int max_distance) const;

  // BoW search between a keyframe's map points and a frame's keypoints (both
  // with BoW computed). `matches` gets one map point (or nullptr) per frame
  // keypoint. Returns the number of matches.
  int SearchByBow(const KeyFrame& keyframe, const Frame& frame,
                  std::vector<MapPoint*>* matches) const;

  // Pairs of keypoints (index in kf1, index in kf2) without map points, in a
  // shared vocabulary node, with distance <= kHammingLow and the kf2 keypoint
  // within 3.84 sigma^2 of the epipolar line of the kf1 keypoint; when neither
  // has depth, kf2 keypoints close to the epipole are skipped. With
  // `only_with_depth`, both keypoints need depth. Each kf2 keypoint is used
  // once. Returns pairs ordered by kf1 index.
  int SearchForTriangulation(const KeyFrame& kf1, const KeyFrame& kf2, const Eigen::Matrix3d& F12,
                             bool only_with_depth,
                             std::vector<std::pair<uint32_t, uint32_t>>* pairs) const;

  // Projects `points` into `keyframe` and fuses each with the best keypoint
  // (distance <= kHammingLow, reprojection error within the chi-square bound,
  // level in [predicted - 1, predicted]) in a window of th * scale: a keypoint
  // that already has a map point keeps the one with more observations (the
  // other is replaced), otherwise the point gains the observation. Returns
  // the number of fused points.
  int Fuse(KeyFrame* keyframe, const std::vector<MapPoint*>& points, Map* map,
           double th = 3.0) const;

  // --- Loop closing (ORB-SLAM2's keyframe-to-keyframe searches) ---

  // BoW search between two keyframes' map points: for each kf1 keypoint with
  // a good map point, the nearest kf2 keypoint with a good map point in the
  // same vocabulary node, distance < kHammingLow and Lowe's ratio; each kf2
  // keypoint used once. `matches12` gets kf2's map point (or nullptr) per kf1
  // keypoint. Returns the number of matches.
  int SearchByBow(const KeyFrame& kf1, const KeyFrame& kf2,
                  std::vector<MapPoint*>* matches12) const;

  // Guided search between two keyframes given T_12 (maps kf2 camera
  // coordinates to kf1's): kf1's unmatched map points are projected into kf2
  // and kf2's into kf1, each matched to the nearest keypoint (distance <=
  // kHammingHigh) within th * scale at the predicted level or the one
  // below; a pair is added to `matches12` (per kf1 keypoint, as above) when
  // both directions agree (ORB-SLAM2's SearchBySim3 with scale 1). Returns
  // the number of new matches.
  int SearchByRelativePose(const KeyFrame& kf1, const KeyFrame& kf2, const Rigid3d& T_12, double th,
                           std::vector<MapPoint*>* matches12) const;

  // Projects `points` (not already in `matched`) into `keyframe` with pose
  // `T_cam_world` and matches each to the nearest keypoint without a match in
  // `matched` within th * scale at the predicted level or the one below,
  // distance <= kHammingLow, seen at less than 60 degrees from the point's
  // normal. `matched` holds one map point (or nullptr) per keypoint of
  // `keyframe`. Returns the number of new matches.
  int SearchByProjection(const KeyFrame& keyframe, const Rigid3d& T_cam_world,
                         const std::vector<MapPoint*>& points, double th,
                         std::vector<MapPoint*>* matched) const;

  // Loop fusion (ORB-SLAM2's Fuse with a corrected pose): projects `points`
  // not observed by `keyframe` with its current pose; the best keypoint
  // (distance <= kHammingLow, level predicted - 1 .. predicted, within th *
  // scale) gains the observation when it has no map point; when it has one,
  // that point is to be replaced by the projected one: `replace` (one entry
  // per element of `points`) gets it. Returns the number of points fused or
  // to be replaced.
  int FuseForLoop(KeyFrame* keyframe, const std::vector<MapPoint*>& points, Map* map, double th,
                  std::vector<MapPoint*>* replace) const;

 private:
  const SensorModel& sensor_;
  double nn_ratio_;
  bool check_orientation_;
};

}  // namespace rrslam
