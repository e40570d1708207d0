// Synthetic scenes for the track stage's unit tests: random 3-D points with
// random ORB descriptors, seen by pinhole cameras as keypoints with exact or
// noisy pixels, depth and descriptors. Header-only; tests only.
#pragma once

#include <gtest/gtest.h>

#include <Eigen/Core>
#include <memory>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "common/geometry.h"
#include "common/settings.h"
#include "stages/track/data/frame.h"
#include "stages/track/data/map.h"
#include "stages/track/data/sensor_model.h"

namespace rrslam::testing {

// 640 x 480, f = 500 px, bf = 40 (baseline 8 cm), ThDepth 40 (3.2 m), 8 levels of 1.2.
inline Settings TestSettings() {
  Settings s;
  s.fx = s.fy = 500;
  s.cx = 320;
  s.cy = 240;
  s.width = 640;
  s.height = 480;
  s.bf = 40;
  s.th_depth = 40;
  return s;
}

inline SensorModel TestSensor() { return SensorModel(TestSettings(), 640, 480); }

inline OrbDescriptor RandomDescriptor(std::mt19937& rng) {
  OrbDescriptor d;
  for (uint8_t& b : d.bytes) b = static_cast<uint8_t>(rng() & 0xff);
  return d;
}

// `d` with `n` distinct random bits flipped.
inline OrbDescriptor FlipBits(OrbDescriptor d, int n, std::mt19937& rng) {
  std::vector<int> bits(256);
  for (int i = 0; i < 256; ++i) bits[i] = i;
  std::shuffle(bits.begin(), bits.end(), rng);
  for (int i = 0; i < n; ++i) d.SetBit(bits[i], !d.Bit(bits[i]));
  return d;
}

struct ScenePoint {
  Eigen::Vector3d position;
  OrbDescriptor descriptor;
};

// Points uniformly in [-2, 2] x [-1.5, 1.5] x [z_min, z_max] (world frame).
inline std::vector<ScenePoint> RandomScene(int n, std::mt19937& rng, double z_min = 2.0,
                                           double z_max = 3.0) {
  std::uniform_real_distribution<double> ux(-2, 2), uy(-1.5, 1.5), uz(z_min, z_max);
  std::vector<ScenePoint> points(n);
  for (ScenePoint& p : points) {
    p.position = Eigen::Vector3d(ux(rng), uy(rng), uz(rng));
    p.descriptor = RandomDescriptor(rng);
  }
  return points;
}

struct ViewOptions {
  double pixel_noise = 0.0;  // Gaussian sigma, pixels.
  int flipped_bits = 0;      // Bits flipped in each descriptor.
  bool with_depth = true;    // Keypoints get the exact depth.
  int distractors = 0;       // Extra keypoints with random descriptors and positions.
};

// Keypoints of the points visible from T_cam_world (octave 0, angle 0).
// point_of[i] is the scene point of keypoint i, -1 for distractors.
struct SyntheticView {
  std::vector<Keypoint> keypoints;
  std::vector<OrbDescriptor> descriptors;
  std::vector<int> point_of;
};

inline SyntheticView RenderView(const SensorModel& sensor, const std::vector<ScenePoint>& points,
                                const Rigid3d& T_cam_world, std::mt19937& rng,
                                const ViewOptions& options = {}) {
  SyntheticView view;
  std::normal_distribution<double> noise(0.0, options.pixel_noise);
  for (size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector3d pc = T_cam_world * points[i].position;
    if (pc.z() <= 0.1) continue;
    Eigen::Vector2d px = sensor.Project(pc);
    if (options.pixel_noise > 0) px += Eigen::Vector2d(noise(rng), noise(rng));
    if (!sensor.bounds.Contains(px.x(), px.y())) continue;
    Keypoint kp;
    kp.pixel = Eigen::Vector2f(px.cast<float>());
    kp.undistorted = kp.pixel;
    kp.depth = options.with_depth ? static_cast<float>(pc.z()) : 0.0f;
    view.keypoints.push_back(kp);
    view.descriptors.push_back(options.flipped_bits > 0
                                   ? FlipBits(points[i].descriptor, options.flipped_bits, rng)
                                   : points[i].descriptor);
    view.point_of.push_back(static_cast<int>(i));
  }
  std::uniform_real_distribution<double> uu(0, 639), uv(0, 479);
  for (int k = 0; k < options.distractors; ++k) {
    Keypoint kp;
    kp.pixel = Eigen::Vector2f(uu(rng), uv(rng));
    kp.undistorted = kp.pixel;
    kp.depth = options.with_depth ? 2.5f : 0.0f;
    view.keypoints.push_back(kp);
    view.descriptors.push_back(RandomDescriptor(rng));
    view.point_of.push_back(-1);
  }
  return view;
}

inline Frame MakeFrame(const SensorModel& sensor, const SyntheticView& view, uint64_t id,
                       const Rigid3d& T_cam_world) {
  Frame frame(id, static_cast<double>(id),
              BuildFrameFeatures(sensor, view.keypoints, view.descriptors));
  frame.SetPose(T_cam_world);
  return frame;
}

// A map point at a scene point, with its descriptor, a normal towards
// `centre` and scale distances for octave 0 at its distance from `centre`.
inline MapPoint* MakeFreePoint(Map* map, const SensorModel& sensor, const ScenePoint& p,
                               const Eigen::Vector3d& centre) {
  MapPoint* point = map->CreateMapPoint(p.position, nullptr);
  point->SetDescriptor(p.descriptor);
  const Eigen::Vector3d ray = p.position - centre;
  const double d = ray.norm();
  point->SetNormalAndDistances(ray / d, d / sensor.pyramid.scale.back(), d);
  map->AddMapPoint(point);
  return point;
}

// Distance between the camera centres of two T_cam_world poses, metres.
inline double TranslationError(const Rigid3d& a, const Rigid3d& b) {
  return (a.Inverse().translation - b.Inverse().translation).norm();
}

// A small pose change: rotation of `angle_rad` about a fixed axis and a
// translation of `metres`.
inline Rigid3d SmallMotion(double angle_rad, double metres) {
  return Rigid3d(ExpSO3(Eigen::Vector3d(0.3, -0.8, 0.5).normalized() * angle_rad),
                 Eigen::Vector3d(0.6, 0.2, -0.77).normalized() * metres);
}

}  // namespace rrslam::testing

namespace rrslam::testing {

// A keyframe (added to the map unless `add_to_map` is false, as a keyframe
// the tracker just made) with `n` keypoints on a grid, each with `depth`
// metres (0 = none) and octave `octave`, random descriptors.
inline KeyFrame* MakeGridKeyFrame(Map* map, const SensorModel& sensor, int n,
                                  const Rigid3d& T_cam_world, std::mt19937& rng, float depth = 2.0f,
                                  int octave = 0, bool add_to_map = true) {
  SyntheticView view;
  for (int i = 0; i < n; ++i) {
    Keypoint kp;
    kp.pixel = Eigen::Vector2f(20.0f + 15.0f * (i % 40), 20.0f + 15.0f * (i / 40));
    kp.undistorted = kp.pixel;
    kp.depth = depth;
    kp.octave = static_cast<uint8_t>(octave);
    view.keypoints.push_back(kp);
    view.descriptors.push_back(RandomDescriptor(rng));
    view.point_of.push_back(i);
  }
  KeyFrame* kf =
      map->CreateKeyFrame(MakeFrame(sensor, view, map->num_created_keyframes(), T_cam_world));
  if (add_to_map) map->AddKeyFrame(kf);
  return kf;
}

// A map point (added to the map) observed by keyframes[j] at keypoint indices[j].
// EXPECT_TRUE(MapIsConsistent(map)): the map's invariants hold
// (Map::CheckInvariants), else the first violated one is the message.
inline ::testing::AssertionResult MapIsConsistent(const Map& map) {
  std::string why;
  if (map.CheckInvariants(&why)) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure() << why;
}

inline MapPoint* MakeObservedPoint(Map* map, const std::vector<KeyFrame*>& keyframes,
                                   const std::vector<uint32_t>& indices,
                                   const Eigen::Vector3d& position = Eigen::Vector3d(0, 0, 2)) {
  MapPoint* point = map->CreateMapPoint(position, keyframes.front());
  for (size_t j = 0; j < keyframes.size(); ++j)
    map->AddObservation(point, keyframes[j], indices[j]);
  map->AddMapPoint(point);
  return point;
}

}  // namespace rrslam::testing

namespace rrslam::testing {

// A DBoW2 text vocabulary with k = 10, L = 2 (100 words), L1 scoring, tf-idf
// weighting, random node descriptors and weight 1.
inline std::string HundredWordVocabularyText() {
  std::mt19937 rng(17);
  std::ostringstream text;
  text << "10 2  0 0\n";
  auto node = [&](int parent, int leaf) {
    text << parent << " " << leaf << " ";
    const OrbDescriptor d = RandomDescriptor(rng);
    for (uint8_t b : d.bytes) text << int(b) << " ";
    text << " 1\n";
  };
  for (int i = 0; i < 10; ++i) node(0, 0);
  for (int parent = 1; parent <= 10; ++parent) {
    for (int i = 0; i < 10; ++i) node(parent, 1);
  }
  return text.str();
}

// That vocabulary, loaded.
inline Vocabulary HundredWordVocabulary() {
  const std::string s = HundredWordVocabularyText();
  return Vocabulary::FromBytes({reinterpret_cast<const uint8_t*>(s.data()), s.size()}, "test");
}

// Adds a keyframe of `view` at T_cam_world to `map` and ties each keypoint to
// the map point of its scene point, made at the point's true position when
// first seen (`points`: one slot per scene point, null until then).
inline KeyFrame* AddViewKeyFrame(const SensorModel& sensor, const SyntheticView& view, uint64_t id,
                                 const Rigid3d& T_cam_world, const std::vector<ScenePoint>& scene,
                                 Map* map, std::vector<MapPoint*>* points) {
  KeyFrame* kf = map->CreateKeyFrame(MakeFrame(sensor, view, id, T_cam_world));
  map->AddKeyFrame(kf);
  for (size_t i = 0; i < view.point_of.size(); ++i) {
    const int p = view.point_of[i];
    if ((*points)[p] == nullptr) {
      (*points)[p] = map->CreateMapPoint(scene[p].position, kf);
      map->AddMapPoint((*points)[p]);
    }
    map->AddObservation((*points)[p], kf, static_cast<uint32_t>(i));
  }
  return kf;
}

// Five keyframes along a path over a random scene, every keypoint tied to
// the map point of its scene point; exact pixels and depths (every third
// keypoint without depth). The map's root is keyframe 0.
class KeyFrameChainScene {
 public:
  KeyFrameChainScene() {
    scene_ = RandomScene(200, rng_, 2.0, 4.0);
    points_.assign(scene_.size(), nullptr);
    for (int k = 0; k < 5; ++k) {
      truth_.push_back(SmallMotion(0.02 * k, 0.08 * k));
      AddKeyFrame(truth_[k]);
    }
    for (KeyFrame* kf : keyframes_) map_.UpdateConnections(kf);
  }

  // A keyframe at T_cam_world seeing the scene from truth_ pose `T_true`.
  KeyFrame* AddKeyFrame(const Rigid3d& T_true, const Rigid3d* T_cam_world = nullptr) {
    SyntheticView view = RenderView(sensor_, scene_, T_true, rng_);
    for (size_t i = 0; i < view.keypoints.size(); i += 3) view.keypoints[i].depth = 0;
    KeyFrame* kf =
        AddViewKeyFrame(sensor_, view, keyframes_.size(),
                        T_cam_world != nullptr ? *T_cam_world : T_true, scene_, &map_, &points_);
    keyframes_.push_back(kf);
    return kf;
  }

  // Keyframes 1.. moved off the truth, points by 2 cm noise.
  void Perturb() {
    for (size_t k = 1; k < keyframes_.size(); ++k) {
      keyframes_[k]->SetPose(SmallMotion(0.01 * (k % 2 ? 1 : -1), 0.03) * truth_[k]);
    }
    std::normal_distribution<double> noise(0.0, 0.02);
    for (MapPoint* p : points_) {
      if (p == nullptr) continue;
      p->SetPosition(p->position_world() + Eigen::Vector3d(noise(rng_), noise(rng_), noise(rng_)));
    }
  }

  std::mt19937 rng_{51};
  SensorModel sensor_ = TestSensor();
  std::vector<ScenePoint> scene_;
  std::vector<Rigid3d> truth_;
  Map map_;
  std::vector<KeyFrame*> keyframes_;
  std::vector<MapPoint*> points_;
};

}  // namespace rrslam::testing
