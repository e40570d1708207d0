#include "stages/track/module/loop_closer.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <iostream>
#include <mutex>
#include <random>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "stages/track/test_scene.h"

namespace rrslam {
namespace {

using testing::MakeFrame;
using testing::RandomScene;
using testing::RenderView;
using testing::ScenePoint;
using testing::SmallMotion;
using testing::TestSensor;
using testing::TranslationError;
using testing::ViewOptions;

constexpr double kDeg = M_PI / 180;

// `scene` scaled by `scale` about its centroid, with x mirrored about the
// centroid when `mirror`; same descriptors.
std::vector<ScenePoint> Reshaped(const std::vector<ScenePoint>& scene, double scale,
                                 bool mirror = false) {
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  for (const ScenePoint& p : scene) centroid += p.position;
  centroid /= static_cast<double>(scene.size());
  std::vector<ScenePoint> copy = scene;
  for (ScenePoint& p : copy) {
    Eigen::Vector3d offset = p.position - centroid;
    if (mirror) offset.x() = -offset.x();
    p.position = centroid + scale * offset;
  }
  return copy;
}

// The T_cam_world that sees `scene` scaled by `scale` about its centroid as
// T_cam_world sees `scene`: the camera centre scaled with it. The image is
// the same; only the depths are `scale` times larger.
Rigid3d ScaledViewpoint(const std::vector<ScenePoint>& scene, double scale,
                        const Rigid3d& T_cam_world) {
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  for (const ScenePoint& p : scene) centroid += p.position;
  centroid /= static_cast<double>(scene.size());
  const Rigid3d T_world_cam = T_cam_world.Inverse();
  return Rigid3d(T_world_cam.rotation, centroid + scale * (T_world_cam.translation - centroid))
      .Inverse();
}

std::string Describe(bool passed, const LoopCandidateMatch& m) {
  std::ostringstream s;
  s << "passed " << passed << ", " << m.bow_matches << " BoW matches, " << m.ransac_inliers
    << " RANSAC inliers, " << m.inliers << " optimized inliers, " << m.matches << " matches";
  return s.str();
}

// Where the copy of the texture is in the world: another part of the room,
// 90 degrees around and 6.7 m away.
const Rigid3d kElsewhere(ExpSO3(Eigen::Vector3d(0, 0.5 * M_PI, 0)), Eigen::Vector3d(6, 0, 3));

// The geometric check of a loop candidate (LoopCloser::CheckCandidate, step
// 2) between two keyframes C (the candidate, the earlier visit) and Q (the
// keyframe checked, the later visit), each with map points of its own: a
// random scene of 300 points 2-4 m in front of the cameras, keypoints at
// octave 0 with depth, the test vocabulary of 100 words.
class LoopCloserTest : public ::testing::Test {
 protected:
  // A keyframe rendered from `T_render` over `scene` (positions in the
  // render frame R), with one new map point per keypoint. Its map lives in
  // the world frame W = placement * R: the keyframe's pose is T_render *
  // placement^-1 and its points are at placement * position, so in camera
  // coordinates everything is where it was rendered. 0.3 px of pixel noise,
  // exact depth, 4 bits flipped per descriptor; BoW computed.
  KeyFrame* AddKeyFrame(const std::vector<ScenePoint>& scene, const Rigid3d& T_render,
                        const Rigid3d& placement) {
    ViewOptions options;
    options.pixel_noise = 0.3;
    options.flipped_bits = 4;
    const testing::SyntheticView view = RenderView(sensor_, scene, T_render, rng_, options);
    KeyFrame* kf = map_.CreateKeyFrame(
        MakeFrame(sensor_, view, map_.num_created_keyframes(), T_render * placement.Inverse()));
    map_.AddKeyFrame(kf);
    for (size_t i = 0; i < view.point_of.size(); ++i) {
      MapPoint* point = map_.CreateMapPoint(placement * scene[view.point_of[i]].position, kf);
      map_.AddMapPoint(point);
      map_.AddObservation(point, kf, static_cast<uint32_t>(i));
      point->ComputeDistinctiveDescriptor();
      point->UpdateNormalAndDepth(sensor_.pyramid);
      scene_point_of_.resize(point->id() + 1, -1);
      scene_point_of_[point->id()] = view.point_of[i];
    }
    map_.UpdateConnections(kf);
    kf->ComputeBow(vocabulary_, FeatureVectorLevelsUp(vocabulary_.levels(), false));
    return kf;
  }

  bool Check(KeyFrame* keyframe, KeyFrame* candidate, LoopCandidateMatch* match) {
    std::lock_guard<std::mutex> lock(map_.mutex());  // CheckCandidate's caller holds it.
    return closer_.CheckCandidate(keyframe, candidate, match);
  }

  // The index of the scene point a map point was made for.
  int SceneIndex(const MapPoint* point) const { return scene_point_of_.at(point->id()); }

  std::mt19937 rng_{23};
  SensorModel sensor_ = TestSensor();
  Vocabulary vocabulary_ = testing::HundredWordVocabulary();
  Map map_;
  KeyFrameDatabase database_{vocabulary_};
  LocalMapper mapper_{sensor_, vocabulary_, &map_, &database_};  // Not started.
  LoopCloser closer_{sensor_, vocabulary_, &map_, &database_, &mapper_};
  const LoopClosingOptions options_;  // The loop closer's (defaults).
  std::vector<int> scene_point_of_;   // Per map point id.
  std::vector<ScenePoint> scene_ = RandomScene(300, rng_, 2.0, 4.0);
  // C's pose (true world frame) and Q's true pose, 22 cm and 5 degrees apart.
  const Rigid3d T_c_ = SmallMotion(0.02, 0.05);
  const Rigid3d T_q_{ExpSO3(Eigen::Vector3d(0.03, -0.08, 0.02)), Eigen::Vector3d(0.2, -0.05, 0.1)};
};

// Q revisits C's scene, but Q's map has drifted by D (3 degrees, 10 cm): its
// pose and points are in the drifted frame. The check matches Q's points to
// C's and finds Q's true pose in C's (undrifted) frame.
TEST_F(LoopCloserTest, GeometricCheckAcceptsATrueLoop) {
  KeyFrame* c = AddKeyFrame(scene_, T_c_, Rigid3d::Identity());
  const Rigid3d D(ExpSO3(Eigen::Vector3d(1, 2, -1).normalized() * 3 * kDeg),
                  Eigen::Vector3d(0.06, -0.03, 0.075));
  ASSERT_NEAR(D.translation.norm(), 0.1, 0.001);
  KeyFrame* q = AddKeyFrame(scene_, T_q_, D);
  ASSERT_GT(c->size(), 100u);
  ASSERT_GT(q->size(), 100u);
  // Q's own pose is off by the drift.
  ASSERT_GT(TranslationError(q->T_cam_world(), T_q_), 0.1);
  ASSERT_GT(RotationAngle(q->T_cam_world().rotation, T_q_.rotation), 2.5 * kDeg);

  LoopCandidateMatch match;
  const bool passed = Check(q, c, &match);
  ASSERT_TRUE(passed) << Describe(passed, match);
  EXPECT_EQ(match.matched, c);
  EXPECT_GE(match.bow_matches, options_.min_bow_matches);
  EXPECT_GT(match.ransac_inliers, options_.ransac.min_inliers);
  EXPECT_GE(match.inliers, options_.min_optimized_inliers);
  // The loop closes: most of Q's keypoints found C's point.
  EXPECT_GE(match.matches, options_.min_loop_matches) << Describe(passed, match);
  EXPECT_GT(match.matches, static_cast<int>(q->size()) / 2) << Describe(passed, match);
  // Each with C's point of the same scene point.
  ASSERT_EQ(match.matched_points.size(), q->size());
  int wrong = 0;
  for (size_t i = 0; i < q->size(); ++i) {
    const MapPoint* loop_point = match.matched_points[i];
    if (loop_point == nullptr) continue;
    EXPECT_TRUE(loop_point->IsObservedBy(c)) << i;
    if (SceneIndex(loop_point) != SceneIndex(q->map_point(i))) ++wrong;
  }
  EXPECT_EQ(wrong, 0);
  // Q's true pose in C's world frame.
  EXPECT_LT(TranslationError(match.T_cam_world, T_q_), 0.01);
  EXPECT_LT(RotationAngle(match.T_cam_world.rotation, T_q_.rotation), 0.2 * kDeg);
}

// Near-duplicate texture in another place of the room: Q sees a copy of C's
// texture elsewhere (kElsewhere), printed 1.3 times larger (C's scene scaled
// about its centroid, the same descriptors with a few bits flipped). ORB
// descriptors match across scale, so BoW matching pairs nearly every
// keypoint; depth gives metric scale, so no rigid transform explains the
// matches and the rigid RANSAC (umeyama without scale on 3-D points) finds
// no hypothesis: the geometry, not the descriptors, rejects the candidate.
// Two viewpoints of the copy: the same pose relative to the copy as the true
// loop's, and the pose from which the copy looks exactly like C's scene
// (camera centre scaled with it; only depths differ, by 1.3).
TEST_F(LoopCloserTest, GeometricCheckRejectsNearDuplicateTextureAtAnotherScale) {
  KeyFrame* c = AddKeyFrame(scene_, T_c_, Rigid3d::Identity());
  const std::vector<ScenePoint> larger = Reshaped(scene_, 1.3);
  for (const Rigid3d& T_render : {T_q_, ScaledViewpoint(scene_, 1.3, T_q_)}) {
    KeyFrame* q = AddKeyFrame(larger, T_render, kElsewhere);
    SCOPED_TRACE(q->id());
    ASSERT_GT(q->size(), 100u);
    LoopCandidateMatch match;
    const bool passed = Check(q, c, &match);
    EXPECT_FALSE(passed) << Describe(passed, match);
    // BoW matching found far more than the loop would need.
    EXPECT_GE(match.bow_matches, 100) << Describe(passed, match);
    EXPECT_GE(match.bow_matches, options_.min_loop_matches);
    // RANSAC rejected it (no hypothesis with more than min_inliers), far
    // from the bar; nothing after it ran.
    EXPECT_LT(match.ransac_inliers, options_.ransac.min_inliers / 2) << Describe(passed, match);
    EXPECT_EQ(match.matched, nullptr);
    EXPECT_EQ(match.inliers, 0);
    EXPECT_EQ(match.matches, 0);
  }
}

// The copy mirrored (x negated about its centroid; descriptors kept, which
// a real mirror image would not even do). Larger as above, RANSAC rejects
// it outright. At the same size, the points near the mirror plane do
// coincide with their originals, so a rigid hypothesis can gather about 20
// inliers (RANSAC's bar is more than 20): with another scene the check may
// pass the RANSAC and the optimization with about 20 inliers, but the loop
// stays far below the 40 matches it needs.
TEST_F(LoopCloserTest, GeometricCheckRejectsMirroredDuplicateTexture) {
  KeyFrame* c = AddKeyFrame(scene_, T_c_, Rigid3d::Identity());
  {
    KeyFrame* q = AddKeyFrame(Reshaped(scene_, 1.3, true), T_q_, kElsewhere);
    LoopCandidateMatch match;
    const bool passed = Check(q, c, &match);
    EXPECT_FALSE(passed) << Describe(passed, match);
    EXPECT_GE(match.bow_matches, 100) << Describe(passed, match);
    EXPECT_LT(match.ransac_inliers, options_.ransac.min_inliers / 2) << Describe(passed, match);
    EXPECT_EQ(match.matches, 0);
  }
  {
    KeyFrame* q = AddKeyFrame(Reshaped(scene_, 1.0, true), T_q_, kElsewhere);
    LoopCandidateMatch match;
    const bool passed = Check(q, c, &match);
    EXPECT_GE(match.bow_matches, 100) << Describe(passed, match);
    EXPECT_LE(match.ransac_inliers, 2 * options_.ransac.min_inliers) << Describe(passed, match);
    EXPECT_TRUE(!passed || match.matches < options_.min_loop_matches) << Describe(passed, match);
  }
}

// The known limit: an exact copy of the texture elsewhere (scale 1) is
// geometrically indistinguishable from a loop. The check accepts it and
// returns the pose Q would have if the copy were C's scene: closing this
// "loop" would move Q by the whole placement of the copy. Only the
// detection's consistency over 3 keyframes and their covisibility groups
// guard against it.
TEST_F(LoopCloserTest, GeometricCheckAcceptsAnExactDuplicateElsewhere) {
  KeyFrame* c = AddKeyFrame(scene_, T_c_, Rigid3d::Identity());
  KeyFrame* q = AddKeyFrame(scene_, T_q_, kElsewhere);
  LoopCandidateMatch match;
  const bool passed = Check(q, c, &match);
  ASSERT_TRUE(passed) << Describe(passed, match);
  EXPECT_GE(match.matches, options_.min_loop_matches) << Describe(passed, match);
  EXPECT_LT(TranslationError(match.T_cam_world, T_q_), 0.01);
  EXPECT_LT(RotationAngle(match.T_cam_world.rotation, T_q_.rotation), 0.2 * kDeg);
  // Q's actual pose, with the copy 6.7 m away and turned by 90 degrees.
  EXPECT_GT(TranslationError(match.T_cam_world, q->T_cam_world()), 5.0);
}

// Loop closing with its threads: a walk along a textured wall (the earlier
// part of the map, exact), then a later visit of part of it whose map has
// drifted; the keyframes of the later visit are handed to the loop closer as
// local mapping would.
//  - The earlier part: keyframes K0..K11, 0.8 m apart along x, looking at a
//    wall of random points 14.8 m long, 2-4 m away; each scene point seen is
//    one map point shared by the keyframes that see it (so consecutive
//    keyframes are covisible). The map's root is K0.
//  - A later visit Q1..Q4 near the viewpoints of K2..K5, with a map of its
//    own in a drifted frame (`kDriftQ`): its own map points (the same scene
//    points, descriptors with other flipped bits), shared among the Q's but
//    with none of the K's, so the Q's are connected only to each other.
// Detection: a candidate group needs 4 consecutive keyframes (the first
// detection and 3 consistent ones), so the loop closes at Q4.
class LoopCloserThreadsTest : public LoopCloserTest {
 protected:
  static constexpr int kEarlier = 12;  // K0..K11.
  static constexpr double kSpacing = 0.8;

  // Q's map has drifted by 4 degrees (about the world origin) and 20 cm:
  // Q4's camera is 0.4 m off.
  const Rigid3d kDriftQ{ExpSO3(Eigen::Vector3d(1, -2, 1).normalized() * 4 * kDeg),
                        Eigen::Vector3d(0.12, -0.06, 0.15)};
  // A second later visit R1..R4 near K7..K10, drifted otherwise.
  const Rigid3d kDriftR{ExpSO3(Eigen::Vector3d(-1, 1, 2).normalized() * 3 * kDeg),
                        Eigen::Vector3d(-0.1, 0.08, -0.12)};

  // The pose (T_cam_world) of a camera at `centre` turned by `rotation`.
  static Rigid3d Viewpoint(const Eigen::Vector3d& centre, const Eigen::Vector3d& rotation) {
    return Rigid3d(ExpSO3(rotation), centre).Inverse();
  }
  static Rigid3d EarlierPose(int i) {
    return Viewpoint(Eigen::Vector3d(kSpacing * i, 0, 0), Eigen::Vector3d::Zero());
  }
  // Near K_i's viewpoint: 10-15 cm and 2-3 degrees off.
  static Rigid3d RevisitPose(int i) {
    return Viewpoint(Eigen::Vector3d(kSpacing * i + 0.1, 0.05, -0.08),
                     Eigen::Vector3d(0.02, -0.04, 0.01 * (i % 3)));
  }

  // Points uniformly in [-2, 10.8 + 2] x [-1.5, 1.5] x [2, 4]. Their
  // descriptors fall clearly into a word of the test vocabulary, so the
  // same point gives the same word in every view. (Random descriptors are
  // about equally far, 128 bits, from every node of that random vocabulary:
  // a few flipped bits change their word, and the BoW vectors of all views
  // look alike, scoring 0.7-0.8 whatever they see.) Each point picks a random
  // leaf L (child of node P) and takes the bits P and L share, a random half
  // of the bits where they differ from L and the others from P (about 64
  // bits from each), then 16 random bits flipped: about 80 bits from P and L
  // and 128 from every other node, so the descent picks P, then L. Two points
  // of the same word are about 96 bits apart.
  std::vector<ScenePoint> Wall(int n) {
    // The vocabulary's nodes: "parent leaf byte*32 weight" per line after
    // the header, node ids from 1.
    std::istringstream text(testing::HundredWordVocabularyText());
    std::string header;
    std::getline(text, header);
    std::vector<OrbDescriptor> node(1);
    std::vector<int> parent(1, -1);
    std::vector<int> leaves;
    int parent_id, leaf;
    while (text >> parent_id >> leaf) {
      OrbDescriptor d;
      for (uint8_t& b : d.bytes) {
        int v;
        text >> v;
        b = static_cast<uint8_t>(v);
      }
      double weight;
      text >> weight;
      if (leaf) leaves.push_back(static_cast<int>(node.size()));
      node.push_back(d);
      parent.push_back(parent_id);
    }
    EXPECT_EQ(leaves.size(), 100u);
    std::uniform_real_distribution<double> ux(-2, kSpacing * (kEarlier - 1) + 2), uy(-1.5, 1.5),
        uz(2, 4);
    std::uniform_int_distribution<size_t> word(0, leaves.size() - 1);
    std::bernoulli_distribution half(0.5);
    std::vector<ScenePoint> points(n);
    for (ScenePoint& p : points) {
      p.position = Eigen::Vector3d(ux(rng_), uy(rng_), uz(rng_));
      const int l = leaves[word(rng_)];
      const OrbDescriptor& from_leaf = node[l];
      const OrbDescriptor& from_parent = node[parent[l]];
      OrbDescriptor d = from_parent;
      for (int bit = 0; bit < 256; ++bit) {
        if (from_leaf.Bit(bit) != from_parent.Bit(bit) && half(rng_)) {
          d.SetBit(bit, from_leaf.Bit(bit));
        }
      }
      p.descriptor = testing::FlipBits(d, 16, rng_);
    }
    return points;
  }

  // One session of the map: a keyframe rendered from each of `T_true` (true
  // poses) over `scene`, its map in the frame W = placement * true (see
  // LoopCloserTest::AddKeyFrame), one map point per scene point seen,
  // shared by the keyframes of the session that see it. Each keyframe is
  // connected, gets its BoW and enters the keyframe database as local
  // mapping would do it.
  std::vector<KeyFrame*> AddSession(const std::vector<ScenePoint>& scene,
                                    const std::vector<Rigid3d>& T_true, const Rigid3d& placement) {
    std::vector<MapPoint*> point_of_scene(scene.size(), nullptr);
    std::vector<KeyFrame*> keyframes;
    ViewOptions options;
    options.pixel_noise = 0.3;
    options.flipped_bits = 4;
    for (const Rigid3d& T : T_true) {
      const testing::SyntheticView view = RenderView(sensor_, scene, T, rng_, options);
      KeyFrame* kf = map_.CreateKeyFrame(
          MakeFrame(sensor_, view, map_.num_created_keyframes(), T * placement.Inverse()));
      map_.AddKeyFrame(kf);
      for (size_t i = 0; i < view.point_of.size(); ++i) {
        MapPoint*& point = point_of_scene[view.point_of[i]];
        if (point == nullptr) {
          point = map_.CreateMapPoint(placement * scene[view.point_of[i]].position, kf);
          map_.AddMapPoint(point);
        }
        map_.AddObservation(point, kf, static_cast<uint32_t>(i));
      }
      map_.UpdateConnections(kf);
      kf->ComputeBow(vocabulary_, FeatureVectorLevelsUp(vocabulary_.levels(), false));
      database_.Add(kf);
      keyframes.push_back(kf);
    }
    for (MapPoint* point : point_of_scene) {
      if (point == nullptr) continue;
      point->ComputeDistinctiveDescriptor();
      point->UpdateNormalAndDepth(sensor_.pyramid);
    }
    return keyframes;
  }

  void SetUp() override {
    std::vector<Rigid3d> earlier, q;
    for (int i = 0; i < kEarlier; ++i) earlier.push_back(EarlierPose(i));
    for (int i = 2; i <= 5; ++i) q.push_back(RevisitPose(i));
    earlier_ = AddSession(wall_, earlier, Rigid3d::Identity());
    q_true_ = q;
    q_ = AddSession(wall_, q, kDriftQ);
  }

  // R1..R4 (near K7..K10, drifted by kDriftR), made on demand.
  void AddSecondVisit() {
    for (int i = 7; i <= 10; ++i) r_true_.push_back(RevisitPose(i));
    r_ = AddSession(wall_, r_true_, kDriftR);
  }

  // How far the camera of `kf` is from its true pose: metres, degrees.
  static double PositionError(const KeyFrame* kf, const Rigid3d& T_true) {
    return TranslationError(kf->T_cam_world(), T_true);
  }
  static double AngleError(const KeyFrame* kf, const Rigid3d& T_true) {
    return RotationAngle(kf->T_cam_world().rotation, T_true.rotation) / kDeg;
  }
  static bool HasLoopEdge(const KeyFrame* a, const KeyFrame* b) {
    const std::vector<KeyFrame*>& edges = a->loop_edges();
    return std::find(edges.begin(), edges.end(), b) != edges.end();
  }

  // `loop` was closed by `keyframe` with the earlier keyframe K_i, i within
  // 1 of `earlier` (its viewpoint), and both got their loop edge.
  void ExpectLoop(const LoopClosure& loop, const KeyFrame* keyframe, int earlier) const {
    EXPECT_EQ(loop.keyframe, keyframe->id());
    EXPECT_NEAR(static_cast<double>(loop.matched), earlier, 1.0);
    ASSERT_LT(loop.matched, earlier_.size());
    const KeyFrame* matched = earlier_[loop.matched];
    EXPECT_TRUE(HasLoopEdge(keyframe, matched));
    EXPECT_TRUE(HasLoopEdge(matched, keyframe));
    EXPECT_GE(loop.matches, options_.min_loop_matches);
    // The drift, undone: 4 or 3 degrees and 30-40 cm.
    EXPECT_GT(loop.correction_m, 0.2);
    EXPECT_GT(loop.correction_deg, 2.5);
  }

  // The keyframes, once drifted, at their true poses.
  static void ExpectCorrected(const std::vector<KeyFrame*>& keyframes,
                              const std::vector<Rigid3d>& T_true) {
    for (size_t j = 0; j < keyframes.size(); ++j) {
      EXPECT_LT(PositionError(keyframes[j], T_true[j]), 0.02) << keyframes[j]->id();
      EXPECT_LT(AngleError(keyframes[j], T_true[j]), 0.2) << keyframes[j]->id();
    }
  }

  // The earlier part (K0 fixed, the loop keyframe fixed in the essential
  // graph) stays where it was, up to what the global BA adjusts.
  void ExpectEarlierPartKept() const {
    for (int i = 0; i < kEarlier; ++i) {
      EXPECT_LT(PositionError(earlier_[i], EarlierPose(i)), 0.01) << i;
      EXPECT_LT(AngleError(earlier_[i], EarlierPose(i)), 0.1) << i;
    }
  }

  std::vector<ScenePoint> wall_ = Wall(1400);
  std::vector<KeyFrame*> earlier_, q_, r_;
  std::vector<Rigid3d> q_true_, r_true_;
};

// The scene is what the tests need: each part well seen, the Q's drifted.
TEST_F(LoopCloserThreadsTest, SceneIsALoopWithDrift) {
  for (KeyFrame* kf : earlier_) {
    EXPECT_GT(kf->size(), 150u) << kf->id();
    EXPECT_LT(PositionError(kf, EarlierPose(static_cast<int>(kf->id()))), 1e-9);
  }
  for (size_t j = 0; j < q_.size(); ++j) {
    EXPECT_GT(q_[j]->size(), 150u);
    EXPECT_GT(PositionError(q_[j], q_true_[j]), 0.2) << j;
    // Only connected to the other Q's.
    for (const KeyFrame::Connection& c : q_[j]->connections()) {
      EXPECT_NE(std::find(q_.begin(), q_.end(), c.keyframe), q_.end()) << j;
    }
    EXPECT_EQ(q_[j]->connections().size(), q_.size() - 1) << j;
  }
  for (size_t i = 1; i < earlier_.size(); ++i) {
    EXPECT_GE(earlier_[i]->Weight(earlier_[i - 1]), 100) << i;
  }
  // Place recognition can tell the places apart: each Q is most similar to
  // the earlier keyframe at its viewpoint, far less to those 3 or more
  // keyframes (2.4 m) away.
  for (size_t j = 0; j < q_.size(); ++j) {
    const int at = static_cast<int>(j) + 2;
    const double score = vocabulary_.Score(q_[j]->bow(), earlier_[at]->bow());
    EXPECT_GT(score, 0.9) << j;
    for (int i = 0; i < kEarlier; ++i) {
      const double other = vocabulary_.Score(q_[j]->bow(), earlier_[i]->bow());
      if (i != at) {
        EXPECT_LT(other, score - 0.05) << j << " " << i;
      }
      if (std::abs(i - at) >= 3) {
        EXPECT_LT(other, 0.85) << j << " " << i;
      }
    }
  }
}

// Batch mode first (the same scenario, no thread): Q1..Q3 build up the
// consistency of the group around K2..K5, Q4 is accepted, checked, and
// closes the loop with the earlier keyframe at its viewpoint, K5; the
// correction and the global BA (run inline) move the Q's to their true
// poses.
TEST_F(LoopCloserThreadsTest, BatchClosesTheLoop) {
  for (KeyFrame* q : q_) closer_.Enqueue(q);
  closer_.ProcessQueued();
  const LoopClosingCounters& c = closer_.counters();
  EXPECT_EQ(c.keyframes, 4u);
  EXPECT_EQ(c.detections, 1u);
  EXPECT_EQ(c.geometric_fails, 0u);
  ASSERT_EQ(c.loops.size(), 1u);
  ExpectLoop(c.loops[0], q_[3], 5);
  EXPECT_FALSE(c.loops[0].global_ba_aborted);
  EXPECT_GT(c.loops[0].global_ba_ms, 0);
  EXPECT_EQ(c.global_ba.solves, 1u);
  ExpectCorrected(q_, q_true_);
  ExpectEarlierPartKept();
  EXPECT_TRUE(testing::MapIsConsistent(map_));
}

// Realtime: the loop closer's thread takes the keyframes from its queue, the
// correction pauses the running local mapper (idle here) and moves the map
// under its lock, the global BA runs in a thread of its own and pauses the
// mapper again to apply. Stop() finishes the queue and waits for that BA:
// its record is complete after Stop(), and its result applied.
TEST_F(LoopCloserThreadsTest, RealtimeCorrectionRunsGlobalBundleAdjustmentInItsThread) {
  mapper_.Start();
  closer_.Start();
  for (KeyFrame* q : q_) closer_.Enqueue(q);
  closer_.Stop();
  mapper_.Stop();
  const LoopClosingCounters& c = closer_.counters();
  EXPECT_EQ(c.keyframes, 4u);
  EXPECT_EQ(c.detections, 1u);
  ASSERT_EQ(c.loops.size(), 1u);
  ExpectLoop(c.loops[0], q_[3], 5);
  EXPECT_FALSE(c.loops[0].global_ba_aborted);
  EXPECT_GT(c.loops[0].global_ba_ms, 0);
  EXPECT_EQ(c.global_ba.solves, 1u);
  ExpectCorrected(q_, q_true_);
  ExpectEarlierPartKept();
  EXPECT_EQ(mapper_.counters().keyframes, 0u);
}

// The whole realtime pipeline of track.cc: the local mapper's thread
// processes the keyframes of both later visits (Q1..Q4, then R1..R4) and
// hands each to the loop closer through its sink, so loop detection and the
// correction run while the mapper works on the next keyframes: both lock
// the map, and the correction's and the global BA's Pause() wait for the
// mapper to finish the keyframe in progress. R1..R4 come within 10
// keyframes of the loop: no detection for them. (The keyframes are in the
// map already: inserting them again recomputes their BoW and connections,
// and the mapper watches their points as new ones.)
TEST_F(LoopCloserThreadsTest, RealtimeLoopClosingRunsAlongsideLocalMapping) {
  AddSecondVisit();
  mapper_.SetKeyFrameSink([this](KeyFrame* kf) { closer_.Enqueue(kf); });
  mapper_.Start();
  closer_.Start();
  for (KeyFrame* kf : q_) mapper_.Enqueue(kf);
  for (KeyFrame* kf : r_) mapper_.Enqueue(kf);
  mapper_.Stop();  // As track.cc: the mapper first, so every keyframe reached the closer.
  closer_.Stop();
  EXPECT_EQ(mapper_.counters().keyframes, 8u);
  const LoopClosingCounters& c = closer_.counters();
  EXPECT_EQ(c.keyframes, 8u);
  EXPECT_EQ(c.detections, 1u);
  ASSERT_EQ(c.loops.size(), 1u);
  ExpectLoop(c.loops[0], q_[3], 5);
  EXPECT_FALSE(c.loops[0].global_ba_aborted);
  EXPECT_GT(c.loops[0].global_ba_ms, 0);
  ExpectCorrected(q_, q_true_);
}

// Two loops in a row (no wait between loops): Q4 closes the first, and R1
// the second at once, since R1's candidates around K7 share keyframes with
// the group that was consistent for Q4. The second correction aborts the
// first loop's global BA if it still runs (it usually does: the BA of the
// whole map takes longer than R1's detection), then runs its own, which
// Stop() lets finish. Both visits end at their true poses either way.
TEST_F(LoopCloserThreadsTest, SecondCorrectionAbortsTheRunningGlobalBundleAdjustment) {
  AddSecondVisit();
  LoopClosingOptions options;
  options.keyframes_after_loop = 1;  // R1 right after Q4 may close a loop.
  LoopCloser closer(sensor_, vocabulary_, &map_, &database_, &mapper_, options);
  mapper_.Start();
  closer.Start();
  for (KeyFrame* q : q_) closer.Enqueue(q);
  closer.Enqueue(r_[0]);
  closer.Stop();
  mapper_.Stop();
  const LoopClosingCounters& c = closer.counters();
  EXPECT_EQ(c.keyframes, 5u);
  EXPECT_EQ(c.detections, 2u);
  ASSERT_EQ(c.loops.size(), 2u);
  ExpectLoop(c.loops[0], q_[3], 5);
  ExpectLoop(c.loops[1], r_[0], 7);
  // The first BA ended, aborted or not, before the second correction began.
  EXPECT_GT(c.loops[0].global_ba_ms, 0);
  EXPECT_FALSE(c.loops[1].global_ba_aborted);
  EXPECT_GT(c.loops[1].global_ba_ms, 0);
  EXPECT_EQ(c.global_ba.solves, 2u);
  std::cout << "first global BA " << (c.loops[0].global_ba_aborted ? "aborted" : "finished")
            << " after " << c.loops[0].global_ba_ms << " ms; the second took "
            << c.loops[1].global_ba_ms << " ms\n";
  ExpectCorrected(q_, q_true_);
  ExpectCorrected({r_[0]}, {r_true_[0]});
  ExpectEarlierPartKept();
}

// Reset() with the thread running drops the queue and the consistency state
// and restarts the thread: Q1..Q3 (those processed before the reset) count
// for nothing, so Q4 after it is a first detection, not a fourth.
TEST_F(LoopCloserThreadsTest, ResetDropsConsistencyAndRestartsTheThread) {
  mapper_.Start();
  closer_.Start();
  for (size_t j = 0; j < 3; ++j) closer_.Enqueue(q_[j]);
  closer_.Reset();
  closer_.Enqueue(q_[3]);
  closer_.Stop();
  mapper_.Stop();
  const LoopClosingCounters& c = closer_.counters();
  EXPECT_GE(c.keyframes, 1u);  // Q4 at least: the restarted thread ran.
  EXPECT_LE(c.keyframes, 4u);
  EXPECT_EQ(c.detection_ms.size(), c.keyframes);
  EXPECT_EQ(c.detections, 0u);
  EXPECT_TRUE(c.loops.empty());
  EXPECT_TRUE(q_[3]->loop_edges().empty());
}

// Reset() right after a loop was corrected, while its global BA is likely
// running: no deadlock, the BA thread is done when Reset() returns (its
// record complete), and the loop state is gone: with the default options
// R1..R4 (within 10 keyframes of Q4) are checked again, and R4 closes a
// second loop after 4 consistent detections. Whether the BA was aborted is
// not asserted: Reset() aborts a global BA that is still running, and
// whether it still is depends on timing.
TEST_F(LoopCloserThreadsTest, ResetDuringGlobalBundleAdjustment) {
  AddSecondVisit();
  mapper_.Start();
  closer_.Start();
  for (KeyFrame* q : q_) closer_.Enqueue(q);
  // Wait for the correction (the loop edge is added under the map lock);
  // the deadline only turns a failure into a failed test instead of a hang.
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  bool corrected = false;
  while (!corrected && std::chrono::steady_clock::now() < deadline) {
    {
      std::lock_guard<std::mutex> lock(map_.mutex());
      corrected = !q_[3]->loop_edges().empty();
    }
    if (!corrected) std::this_thread::yield();
  }
  ASSERT_TRUE(corrected);
  const auto reset_start = std::chrono::steady_clock::now();
  closer_.Reset();
  const double reset_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - reset_start)
          .count();
  for (KeyFrame* r : r_) closer_.Enqueue(r);
  closer_.Stop();
  mapper_.Stop();
  const LoopClosingCounters& c = closer_.counters();
  EXPECT_EQ(c.keyframes, 8u);
  ASSERT_EQ(c.loops.size(), 2u);
  ExpectLoop(c.loops[0], q_[3], 5);
  EXPECT_GT(c.loops[0].global_ba_ms, 0);
  ExpectLoop(c.loops[1], r_[3], 10);
  EXPECT_FALSE(c.loops[1].global_ba_aborted);
  EXPECT_GT(c.loops[1].global_ba_ms, 0);
  std::cout << "reset took " << reset_ms << " ms; the global BA "
            << (c.loops[0].global_ba_aborted ? "aborted" : "finished") << " after "
            << c.loops[0].global_ba_ms << " ms\n";
  ExpectCorrected(q_, q_true_);
  ExpectCorrected(r_, r_true_);
}

}  // namespace
}  // namespace rrslam
