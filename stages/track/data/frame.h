// Frames: the keypoints of one RGB-D image with their virtual stereo data,
// a grid for radius search (FrameFeatures), what frames and keyframes share
// (View: features, pose, bag of words), and the tracking state of an image.
#pragma once

#include <cstdint>
#include <memory>
#include <mutex>
#include <opencv2/core/mat.hpp>
#include <span>
#include <vector>

#include "common/geometry.h"
#include "common/orb_descriptor.h"
#include "stages/extract/features_file.h"
#include "stages/mapstore/record_array.h"
#include "stages/track/data/sensor_model.h"
#include "stages/vocab/vocabulary.h"

namespace rrslam {

class KeyFrame;
class MapPoint;

// Keypoints and descriptors of one image with the data derived from them
// once: the virtual right coordinate from depth and the search grid (built
// on the first search). Immutable once built (BuildFrameFeatures) and
// shared, never copied, between a Frame and the KeyFrame made from it.
// Thread-safe (const; the grid's first build is once, under std::call_once).
struct FrameFeatures {
  // Undistorted keypoints (Keypoint::undistorted is the ideal pixel used by
  // all geometry; Keypoint::depth is metres, 0 = none) and their
  // descriptors, parallel. A loaded map's keyframes view both in the map
  // file's mapping (record_array.h; LoadMapData), others own them.
  RecordArray<Keypoint> keypoints;
  RecordArray<OrbDescriptor> descriptors;
  // Virtual right-image u of each keypoint, u - bf / depth, ideal pixels;
  // negative when the keypoint has no depth (ORB-SLAM2's mvuRight).
  std::vector<float> u_right;
  size_t size() const { return keypoints.size(); }
  bool HasDepth(size_t i) const { return u_right[i] >= 0; }
  float Depth(size_t i) const { return keypoints[i].depth; }
  int Octave(size_t i) const { return keypoints[i].octave; }
  Eigen::Vector2d Pixel(size_t i) const { return keypoints[i].undistorted.cast<double>(); }

  // Appends to `out` the keypoints with |u - x| < r and |v - y| < r whose
  // octave lies in [min_level, max_level] (max_level < 0: no upper bound),
  // ordered by grid cell then index (ORB-SLAM2's GetFeaturesInArea).
  // `sensor` is the one the features were built with (it lays out the grid).
  void FeaturesInArea(const SensorModel& sensor, double x, double y, double r, int min_level,
                      int max_level, std::vector<uint32_t>* out) const;

 private:
  // Grid cells in CSR layout: keypoints of cell (col, row) are
  // indices[begin[c] .. begin[c + 1]) with c = row * cols + col. 16 kB for
  // 1000 keypoints, built when first searched: most keyframes of a loaded
  // map are never searched by area (localization searches the frame's).
  struct Grid {
    std::vector<uint32_t> begin, indices;
  };
  const Grid& GridFor(const SensorModel& sensor) const;
  mutable std::once_flag grid_built_;
  mutable Grid grid_;
};

// Builds the shared features of an image from keypoints whose `undistorted`
// and `depth` fields are final (FinishKeypoints, a features file or a map
// file). Depths that are not finite or not positive count as no depth (set
// to 0) and octaves beyond the pyramid are clamped to its last level; views
// stay views unless a keypoint needs such a fix (record_array.h).
std::shared_ptr<const FrameFeatures> BuildFrameFeatures(const SensorModel& sensor,
                                                        RecordArray<Keypoint> keypoints,
                                                        RecordArray<OrbDescriptor> descriptors);

// What a frame and a keyframe share: the image's features and timestamp, a
// camera pose and the bag of words of its descriptors.
class View {
 public:
  double timestamp() const { return timestamp_; }
  const FrameFeatures& features() const { return *features_; }
  const std::shared_ptr<const FrameFeatures>& shared_features() const { return features_; }
  size_t size() const { return features_->size(); }

  // Pose. T_cam_world maps world points into this camera.
  bool has_pose() const { return has_pose_; }
  const Rigid3d& T_cam_world() const { return T_cam_world_; }
  const Rigid3d& T_world_cam() const { return T_world_cam_; }
  const Eigen::Matrix3d& R_cam_world() const { return R_cam_world_; }
  const Eigen::Vector3d& camera_centre() const { return T_world_cam_.translation; }
  void SetPose(const Rigid3d& T_cam_world);
  Eigen::Vector3d ToCamera(const Eigen::Vector3d& point_world) const {
    return R_cam_world_ * point_world + T_cam_world_.translation;
  }
  // World point of keypoint i from its depth (requires a pose and
  // features().HasDepth(i)).
  Eigen::Vector3d UnprojectWorld(const SensorModel& sensor, size_t i) const;

  // Bag of words (computed on demand: only keyframes and BoW searches need it).
  bool has_bow() const { return has_bow_; }
  // `levels_up`: the feature vector groups features by their ancestor node
  // that many levels above the words (FeatureVectorLevelsUp).
  void ComputeBow(const Vocabulary& vocabulary, int levels_up);
  const BowVector& bow() const { return bow_; }
  const FeatureVector& feature_vector() const { return feature_vector_; }
  // Sets the bag of words computed elsewhere (tests, tools).
  void SetBow(BowVector bow, FeatureVector feature_vector) {
    bow_ = std::move(bow);
    feature_vector_ = std::move(feature_vector);
    has_bow_ = true;
  }

 protected:
  View() = default;
  View(double timestamp, std::shared_ptr<const FrameFeatures> features)
      : timestamp_(timestamp), features_(std::move(features)) {}

 private:
  double timestamp_ = 0;
  std::shared_ptr<const FrameFeatures> features_;
  bool has_pose_ = false;
  Rigid3d T_cam_world_;
  Rigid3d T_world_cam_;
  Eigen::Matrix3d R_cam_world_ = Eigen::Matrix3d::Identity();
  bool has_bow_ = false;
  BowVector bow_;
  FeatureVector feature_vector_;
};

// The tracking state of one image: its view, map-point associations, outlier
// flags and reference keyframe. Owned by the tracker (one thread); map
// objects it points to belong to Map.
class Frame : public View {
 public:
  Frame() = default;
  Frame(uint64_t id, double timestamp, std::shared_ptr<const FrameFeatures> features);

  uint64_t id() const { return id_; }

  // Map point matched to each keypoint (nullptr = none) and whether pose
  // optimization flagged the match as an outlier.
  std::vector<MapPoint*> map_points;
  std::vector<uint8_t> outlier;

  // Keyframe this frame's pose is expressed against in the trajectory.
  KeyFrame* reference_keyframe = nullptr;

  // Restore mapping: the image's depth in metres (CV_32F, real image pixels
  // as stored, 0 = none) for the change evidence (depth_evidence.h); empty
  // in every other mode, where only the keypoints' depths are kept.
  cv::Mat depth_metres;

 private:
  uint64_t id_ = 0;
};

// Levels above the leaves at which a vocabulary of depth L groups the
// features of a view into its feature vector (the candidate sets of the
// bag-of-words searches). ORB-SLAM2 always groups 4 levels up, at depth L - 4:
// k^2 groups for its L = 6 vocabulary, k groups at L = 5 and the root alone
// (brute force) at L <= 4. With `small_vocabulary_groups` (a departure from
// ORB-SLAM2, option --small-vocab-groups), a vocabulary of fewer than 6 levels
// groups at depth min(2, L - 1) instead, so its searches stay as selective as
// ORB-SLAM2's (k^2 groups at L = 4 or 5); L >= 6 is unchanged.
int FeatureVectorLevelsUp(int vocabulary_levels, bool small_vocabulary_groups);

}  // namespace rrslam
