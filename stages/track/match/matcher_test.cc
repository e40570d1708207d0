#include "stages/track/match/matcher.h"

#include <gtest/gtest.h>

#include <random>

#include "stages/track/test_scene.h"

namespace rrslam {
namespace {

using testing::FlipBits;
using testing::HundredWordVocabulary;
using testing::MakeFrame;
using testing::MakeFreePoint;
using testing::RandomDescriptor;
using testing::RandomScene;
using testing::RenderView;
using testing::SmallMotion;
using testing::TestSensor;
using testing::ViewOptions;

TEST(FeatureVectorTest, GroupsFourLevelsUpAsOrbSlam2ByDefault) {
  for (int levels = 1; levels <= 9; ++levels) EXPECT_EQ(FeatureVectorLevelsUp(levels, false), 4);
}

TEST(FeatureVectorTest, SmallVocabularyGroupsFromSixLevelsAtDepthTwoBelow) {
  for (int levels = 6; levels <= 9; ++levels) EXPECT_EQ(FeatureVectorLevelsUp(levels, true), 4);
  EXPECT_EQ(FeatureVectorLevelsUp(5, true), 3);  // Depth 2 (ORB-SLAM2's 4 up: depth 1).
  EXPECT_EQ(FeatureVectorLevelsUp(4, true), 2);  // Depth 2 (ORB-SLAM2: the root).
  EXPECT_EQ(FeatureVectorLevelsUp(3, true), 1);  // Depth 2.
  EXPECT_EQ(FeatureVectorLevelsUp(2, true), 1);  // Depth 1: never the words themselves.
  EXPECT_EQ(FeatureVectorLevelsUp(1, true), 1);  // The root.
}

TEST(FeatureVectorTest, SmallVocabularyGroupsOfATwoLevelVocabularyAreFirstLevelNodes) {
  // With four levels up every feature would share the root's group; with
  // small-vocabulary groups the frame's feature vector must use the ten
  // first-level nodes (ids 1 to 10).
  const Vocabulary vocabulary = HundredWordVocabulary();
  const SensorModel sensor = TestSensor();
  std::mt19937 rng(11);
  ViewOptions options;
  options.distractors = 200;
  Frame frame = MakeFrame(sensor, RenderView(sensor, {}, Rigid3d(), rng, options), 0, Rigid3d());
  frame.ComputeBow(vocabulary, FeatureVectorLevelsUp(vocabulary.levels(), true));
  const FeatureVector& fv = frame.feature_vector();
  EXPECT_GE(fv.size(), 5u);
  size_t features = 0;
  for (const auto& [node, indices] : fv.entries) {
    EXPECT_GE(node, 1u);
    EXPECT_LE(node, 10u);
    features += indices.size();
  }
  EXPECT_EQ(features, frame.size());
}

// ORB-SLAM2's binning: round(rotation / 30 deg), 13 bins of 30 degrees.
TEST(RotationHistogramTest, BinsAreThirtyDegreesCentredOnMultiplesAsOrbSlam2) {
  EXPECT_EQ(RotationHistogram::kBins, 13);
  EXPECT_EQ(RotationHistogram::Bin(0), 0);
  EXPECT_EQ(RotationHistogram::Bin(14.9f), 0);
  EXPECT_EQ(RotationHistogram::Bin(15.1f), 1);
  EXPECT_EQ(RotationHistogram::Bin(20), 1);
  EXPECT_EQ(RotationHistogram::Bin(40), 1);
  EXPECT_EQ(RotationHistogram::Bin(-12), 12);  // 348 deg.
  EXPECT_EQ(RotationHistogram::Bin(359.9f), 12);
  EXPECT_EQ(RotationHistogram::Bin(344.9f), 11);
  EXPECT_EQ(RotationHistogram::Bin(180), 6);
}

// Orientation noise of +-24 degrees (blur) keeps every true match: 66 .. 114
// deg fall in three 30-degree bins (12-degree bins would spread them over five
// and drop two of them).
TEST(RotationHistogramTest, KeepsNoisyOrientationsOfOneRotation) {
  RotationHistogram h;
  for (int i = 0; i < 25; ++i) h.Add(66.0f + 2 * i, 0, i);
  h.Add(270, 0, 25);  // Inconsistent: a fourth bin.
  EXPECT_EQ(h.Inconsistent(), (std::vector<int>{25}));
}

TEST(RotationHistogramTest, KeepsTheThreeFullestBins) {
  RotationHistogram h;
  int item = 0;
  for (int i = 0; i < 20; ++i) h.Add(10, 10, item++);   // 0 deg: items 0..19
  for (int i = 0; i < 10; ++i) h.Add(100, 10, item++);  // 90 deg: items 20..29
  for (int i = 0; i < 5; ++i) h.Add(190, 10, item++);   // 180 deg: items 30..34
  for (int i = 0; i < 3; ++i) h.Add(280, 10, item++);   // 270 deg: items 35..37
  EXPECT_EQ(h.Inconsistent(), (std::vector<int>{35, 36, 37}));
}

TEST(RotationHistogramTest, DropsSecondAndThirdBinsBelowATenthOfTheFullest) {
  RotationHistogram h;
  for (int i = 0; i < 50; ++i) h.Add(0, 0, i);
  h.Add(0, 90, 50);   // 2 % of the fullest: dropped.
  h.Add(0, 180, 51);  // (Returned in bin order: 180 deg, then 270 deg.)
  EXPECT_EQ(h.Inconsistent(), (std::vector<int>{51, 50}));
}

// Two frames of one scene: the last frame matched to map points, the current
// one rendered after a small motion with noisy pixels and descriptors.
class ProjectionSearchTest : public ::testing::Test {
 protected:
  void SetUp() override {
    scene_ = RandomScene(400, rng_);
    T_last_ = Rigid3d::Identity();
    T_current_ = SmallMotion(0.02, 0.05) * T_last_;
    last_view_ = RenderView(sensor_, scene_, T_last_, rng_);
    ViewOptions options;
    options.pixel_noise = 0.7;
    options.flipped_bits = 8;
    options.distractors = 150;
    current_view_ = RenderView(sensor_, scene_, T_current_, rng_, options);
    last_ = MakeFrame(sensor_, last_view_, 0, T_last_);
    points_.assign(scene_.size(), nullptr);
    for (size_t i = 0; i < last_.size(); ++i) {
      const int p = last_view_.point_of[i];
      points_[p] = MakeFreePoint(&map_, sensor_, scene_[p], last_.camera_centre());
      last_.map_points[i] = points_[p];
    }
  }

  // Fraction of the current frame's matches that name the right point, and
  // their number.
  std::pair<double, int> Score(const Frame& frame) const {
    int matched = 0, correct = 0;
    for (size_t i = 0; i < frame.size(); ++i) {
      if (frame.map_points[i] == nullptr) continue;
      ++matched;
      const int p = current_view_.point_of[i];
      if (p >= 0 && frame.map_points[i] == points_[p]) ++correct;
    }
    return {matched > 0 ? double(correct) / matched : 0.0, matched};
  }

  std::mt19937 rng_{7};
  SensorModel sensor_ = TestSensor();
  std::vector<testing::ScenePoint> scene_;
  Rigid3d T_last_, T_current_;
  testing::SyntheticView last_view_, current_view_;
  Frame last_;
  Map map_;
  std::vector<MapPoint*> points_;
};

TEST_F(ProjectionSearchTest, MotionModelMatchesTheLastFramesPoints) {
  Frame current = MakeFrame(sensor_, current_view_, 1, T_current_);
  const Matcher matcher(sensor_, 0.9, true);
  const int n = matcher.SearchByProjection(&current, last_, 7.0);
  const auto [precision, matched] = Score(current);
  EXPECT_EQ(n, matched);
  // Nearly every point seen in both frames is found, all of them correctly.
  int common = 0;
  for (int p : current_view_.point_of) {
    if (p >= 0 && points_[p] != nullptr) ++common;
  }
  EXPECT_GE(matched, 0.95 * common);
  EXPECT_EQ(precision, 1.0);
}

TEST_F(ProjectionSearchTest, MotionModelFindsNothingFromAFarWrongPose) {
  // A prediction 0.5 m off puts projections tens of pixels from the truth.
  Frame current =
      MakeFrame(sensor_, current_view_, 1,
                Rigid3d(T_current_.rotation, T_current_.translation + Eigen::Vector3d(0.5, 0, 0)));
  const Matcher matcher(sensor_, 0.9, true);
  matcher.SearchByProjection(&current, last_, 7.0);
  const auto [precision, matched] = Score(current);
  EXPECT_LT(matched, 10);
}

TEST_F(ProjectionSearchTest, RotationCheckDropsInconsistentOrientations) {
  // A fifth of the current keypoints turned by angles spread over 48 to 300
  // degrees (about 1% of the matches per bin): with the histogram they are
  // dropped, without it they are kept.
  testing::SyntheticView turned = current_view_;
  std::vector<int> turned_indices;
  for (size_t i = 0; i < turned.keypoints.size(); i += 5) {
    turned.keypoints[i].angle_deg = static_cast<float>(48 + 12 * (turned_indices.size() % 22));
    turned_indices.push_back(static_cast<int>(i));
  }
  Frame with_check = MakeFrame(sensor_, turned, 1, T_current_);
  Frame without_check = MakeFrame(sensor_, turned, 1, T_current_);
  Matcher(sensor_, 0.9, true).SearchByProjection(&with_check, last_, 7.0);
  Matcher(sensor_, 0.9, false).SearchByProjection(&without_check, last_, 7.0);
  int kept_with = 0, kept_without = 0;
  for (int i : turned_indices) {
    kept_with += with_check.map_points[i] != nullptr;
    kept_without += without_check.map_points[i] != nullptr;
  }
  EXPECT_EQ(kept_with, 0);
  EXPECT_GT(kept_without, 10);
}

TEST_F(ProjectionSearchTest, ProjectIntoViewRejectsPointsOutOfView) {
  const Frame current = MakeFrame(sensor_, current_view_, 1, T_current_);
  MapPoint* point = points_[last_view_.point_of[0]];
  ProjectedPoint pp;
  ASSERT_TRUE(ProjectIntoView(sensor_, current.R_cam_world(), current.T_cam_world().translation,
                              current.camera_centre(), point, 0.5, &pp));
  const Eigen::Vector2d expected = sensor_.Project(current.ToCamera(point->position_world()));
  EXPECT_NEAR(pp.u, expected.x(), 1e-9);
  EXPECT_NEAR(pp.v, expected.y(), 1e-9);
  EXPECT_NEAR(pp.u_right, pp.u - sensor_.bf / current.ToCamera(point->position_world()).z(), 1e-9);
  EXPECT_GT(pp.view_cos, 0.99);

  // Behind the camera.
  const Rigid3d turned_around(ExpSO3(Eigen::Vector3d(0, M_PI, 0)), Eigen::Vector3d::Zero());
  EXPECT_FALSE(ProjectIntoView(sensor_, turned_around.RotationMatrix(), turned_around.translation,
                               Eigen::Vector3d::Zero(), point, 0.5, &pp));
  // Beyond its scale-invariance distance.
  const Eigen::Vector3d far_back(0, 0, -20);
  EXPECT_FALSE(
      ProjectIntoView(sensor_, Eigen::Matrix3d::Identity(), -far_back, far_back, point, 0.5, &pp));
  // Seen at 70 degrees from its normal.
  const Eigen::Vector3d n = point->normal();
  const Eigen::Vector3d perpendicular = n.cross(Eigen::Vector3d::UnitY()).normalized();
  const double angle = 70 * M_PI / 180;
  const Eigen::Vector3d aside =
      point->position_world() - 2.0 * (std::cos(angle) * n + std::sin(angle) * perpendicular);
  const Eigen::Matrix3d R_cam_world =
      Eigen::Quaterniond::FromTwoVectors(point->position_world() - aside, Eigen::Vector3d::UnitZ())
          .toRotationMatrix();
  EXPECT_FALSE(ProjectIntoView(sensor_, R_cam_world, -R_cam_world * aside, aside, point, 0.5, &pp));
}

TEST_F(ProjectionSearchTest, LocalMapSearchMatchesPredictedPoints) {
  Frame current = MakeFrame(sensor_, current_view_, 1, T_current_);
  std::vector<ProjectedPoint> predicted;
  for (MapPoint* point : points_) {
    ProjectedPoint pp;
    if (point != nullptr &&
        ProjectIntoView(sensor_, current.R_cam_world(), current.T_cam_world().translation,
                        current.camera_centre(), point, 0.5, &pp)) {
      predicted.push_back(pp);
    }
  }
  ASSERT_GT(predicted.size(), 100u);
  const int n = Matcher(sensor_, 0.8, false).SearchByProjection(&current, predicted, 1.0);
  const auto [precision, matched] = Score(current);
  EXPECT_EQ(n, matched);
  EXPECT_GE(matched, 0.9 * predicted.size());
  EXPECT_EQ(precision, 1.0);
}

TEST_F(ProjectionSearchTest, LocalMapSearchRejectsAmbiguousCandidates) {
  // Two keypoints at the projection with descriptors equally close to the
  // point: the ratio test refuses to choose.
  std::mt19937 rng(3);
  const testing::ScenePoint& sp = scene_[last_view_.point_of[0]];
  MapPoint* point = points_[last_view_.point_of[0]];
  const Eigen::Vector2d px = sensor_.Project(T_current_ * sp.position);
  testing::SyntheticView view;
  for (int k = 0; k < 2; ++k) {
    Keypoint kp;
    kp.pixel = Eigen::Vector2f((px + Eigen::Vector2d(0.5 * k, 0)).cast<float>());
    kp.undistorted = kp.pixel;
    kp.depth = static_cast<float>((T_current_ * sp.position).z());
    view.keypoints.push_back(kp);
    view.descriptors.push_back(FlipBits(sp.descriptor, 20, rng));
    view.point_of.push_back(0);
  }
  Frame current = MakeFrame(sensor_, view, 1, T_current_);
  ProjectedPoint pp;
  ASSERT_TRUE(ProjectIntoView(sensor_, current.R_cam_world(), current.T_cam_world().translation,
                              current.camera_centre(), point, 0.5, &pp));
  EXPECT_EQ(Matcher(sensor_, 0.8, false).SearchByProjection(&current, {pp}, 1.0), 0);
  // With a clearly better candidate the match is made.
  view.descriptors[1] = sp.descriptor;
  Frame clear = MakeFrame(sensor_, view, 1, T_current_);
  EXPECT_EQ(Matcher(sensor_, 0.8, false).SearchByProjection(&clear, {pp}, 1.0), 1);
  EXPECT_EQ(clear.map_points[1], point);
}

// Localization mode matches the frame to temporary points (seen by no
// keyframe) before its local-map search. As in ORB-SLAM2, a keypoint holding
// such a point is still a candidate of the projection searches and the map
// point found there replaces it; a keypoint holding a point that a keyframe
// observes is not.
TEST_F(ProjectionSearchTest, ProjectionSearchesReplaceTemporaryPointsOnly) {
  KeyFrame* keyframe = map_.CreateKeyFrame(last_);
  map_.AddKeyFrame(keyframe);
  const testing::ScenePoint far{Eigen::Vector3d(0, 0, 50), {}};
  MapPoint* temporary = MakeFreePoint(&map_, sensor_, far, Eigen::Vector3d::Zero());
  MapPoint* observed = MakeFreePoint(&map_, sensor_, far, Eigen::Vector3d::Zero());
  map_.AddObservation(observed, keyframe, 0);
  ASSERT_EQ(temporary->num_observations(), 0);
  ASSERT_GT(observed->num_observations(), 0);
  // The last frame's points, given an observation, as map points are.
  std::vector<ProjectedPoint> predicted;
  Frame current = MakeFrame(sensor_, current_view_, 1, T_current_);
  for (size_t i = 0; i < last_.size(); ++i) {
    if (i > 0) map_.AddObservation(last_.map_points[i], keyframe, static_cast<uint32_t>(i));
    ProjectedPoint pp;
    if (ProjectIntoView(sensor_, current.R_cam_world(), current.T_cam_world().translation,
                        current.camera_centre(), last_.map_points[i], 0.5, &pp)) {
      predicted.push_back(pp);
    }
  }
  const auto run = [&](bool motion_model) {
    Frame frame = MakeFrame(sensor_, current_view_, 1, T_current_);
    for (size_t i = 0; i < frame.size(); ++i) frame.map_points[i] = i % 2 ? observed : temporary;
    if (motion_model) {
      Matcher(sensor_, 0.9, true).SearchByProjection(&frame, last_, 7.0);
    } else {
      Matcher(sensor_, 0.8, false).SearchByProjection(&frame, predicted, 1.0);
    }
    int replaced = 0, right = 0, visible_even = 0;
    for (size_t i = 0; i < frame.size(); ++i) {
      const int p = current_view_.point_of[i];
      if (i % 2) {
        EXPECT_EQ(frame.map_points[i], observed) << i;
        continue;
      }
      visible_even += p >= 0 && points_[p] != nullptr;
      if (frame.map_points[i] == temporary) continue;
      ++replaced;
      right += p >= 0 && frame.map_points[i] == points_[p];
    }
    EXPECT_GE(replaced, 0.8 * visible_even) << (motion_model ? "motion model" : "local map");
    EXPECT_EQ(right, replaced) << (motion_model ? "motion model" : "local map");
  };
  run(true);
  run(false);
}

// Feature vectors grouping keypoint i of a view under node (point % nodes);
// distractors go to node 0.
FeatureVector GroupByPoint(const testing::SyntheticView& view, int nodes) {
  std::map<NodeId, std::vector<uint32_t>> groups;
  for (size_t i = 0; i < view.point_of.size(); ++i) {
    const int p = view.point_of[i];
    groups[p >= 0 ? static_cast<NodeId>(p % nodes) : 0].push_back(static_cast<uint32_t>(i));
  }
  FeatureVector fv;
  for (auto& [node, indices] : groups) fv.entries.emplace_back(node, std::move(indices));
  return fv;
}

TEST_F(ProjectionSearchTest, BowSearchMatchesWithinSharedNodes) {
  KeyFrame* keyframe = map_.CreateKeyFrame(last_);
  keyframe->SetBow({}, GroupByPoint(last_view_, 40));
  for (size_t i = 0; i < keyframe->size(); ++i) {
    map_.AddObservation(last_.map_points[i], keyframe, static_cast<uint32_t>(i));
  }
  Frame current = MakeFrame(sensor_, current_view_, 1, T_current_);
  current.SetBow({}, GroupByPoint(current_view_, 40));
  std::vector<MapPoint*> matches;
  const int n = Matcher(sensor_, 0.75, true).SearchByBow(*keyframe, current, &matches);
  int correct = 0, matched = 0;
  for (size_t i = 0; i < matches.size(); ++i) {
    if (matches[i] == nullptr) continue;
    ++matched;
    correct += current_view_.point_of[i] >= 0 && matches[i] == points_[current_view_.point_of[i]];
  }
  EXPECT_EQ(n, matched);
  EXPECT_EQ(correct, matched);
  int common = 0;
  for (int p : current_view_.point_of) common += p >= 0 && points_[p] != nullptr;
  EXPECT_GE(matched, 0.9 * common);

  // Keypoints in different nodes are never matched.
  current.SetBow({}, GroupByPoint(current_view_, 41));
  Matcher(sensor_, 0.75, true).SearchByBow(*keyframe, current, &matches);
  for (size_t i = 0; i < matches.size(); ++i) {
    if (matches[i] == nullptr) continue;
    const int p = current_view_.point_of[i];
    ASSERT_GE(p, 0);
    EXPECT_EQ(p % 40, p % 41);
  }
}

TEST(TriangulationSearchTest, MatchesOnlyAlongEpipolarLines) {
  std::mt19937 rng(11);
  const SensorModel sensor = TestSensor();
  const std::vector<testing::ScenePoint> scene = RandomScene(200, rng);
  const Rigid3d T1 = Rigid3d::Identity();
  const Rigid3d T2 = SmallMotion(0.05, 0.3);
  ViewOptions options;
  options.with_depth = false;
  options.pixel_noise = 0.3;
  testing::SyntheticView v1 = RenderView(sensor, scene, T1, rng, options);
  testing::SyntheticView v2 = RenderView(sensor, scene, T2, rng, options);
  // A decoy in view 2 for every point of view 1: the same descriptor, 30 px
  // off its true position, i.e. off the epipolar line.
  const size_t n2 = v2.keypoints.size();
  for (size_t i = 0; i < n2; ++i) {
    Keypoint decoy = v2.keypoints[i];
    decoy.undistorted.y() += 30;
    decoy.pixel = decoy.undistorted;
    if (!sensor.bounds.Contains(decoy.undistorted.x(), decoy.undistorted.y())) continue;
    v2.keypoints.push_back(decoy);
    v2.descriptors.push_back(v2.descriptors[i]);
    v2.point_of.push_back(-1 - v2.point_of[i]);
  }
  Map map;
  KeyFrame* kf1 = map.CreateKeyFrame(MakeFrame(sensor, v1, 0, T1));
  KeyFrame* kf2 = map.CreateKeyFrame(MakeFrame(sensor, v2, 1, T2));
  // One node for everything: the epipolar check alone must disambiguate.
  auto one_node = [](size_t n) {
    FeatureVector fv;
    fv.entries.emplace_back(0, std::vector<uint32_t>());
    for (size_t i = 0; i < n; ++i) fv.entries[0].second.push_back(static_cast<uint32_t>(i));
    return fv;
  };
  kf1->SetBow({}, one_node(kf1->size()));
  kf2->SetBow({}, one_node(kf2->size()));
  const Eigen::Matrix3d F12 = FundamentalMatrix(sensor, *kf1, *kf2);

  // The fundamental matrix maps true correspondences to x1^T F12 x2 ~ 0.
  const Eigen::Vector3d x1(v1.keypoints[0].undistorted.x(), v1.keypoints[0].undistorted.y(), 1);
  const Eigen::Vector3d p2 = T2 * scene[v1.point_of[0]].position;
  const Eigen::Vector2d u2 = sensor.Project(p2);
  const Eigen::Vector3d l = F12.transpose() * x1;
  EXPECT_LT(std::abs(l.dot(Eigen::Vector3d(u2.x(), u2.y(), 1))) / l.head<2>().norm(), 1.5);

  std::vector<std::pair<uint32_t, uint32_t>> pairs;
  const int n = Matcher(sensor, 0.6, false).SearchForTriangulation(*kf1, *kf2, F12, false, &pairs);
  EXPECT_EQ(n, static_cast<int>(pairs.size()));
  EXPECT_GT(n, 100);
  for (const auto& [i1, i2] : pairs) {
    EXPECT_EQ(v1.point_of[i1], v2.point_of[i2]) << i1 << " " << i2;
  }
  // A keypoint with a map point is not matched again.
  MapPoint* point = map.CreateMapPoint(scene[v1.point_of[pairs[0].first]].position, kf1);
  map.AddObservation(point, kf1, pairs[0].first);
  std::vector<std::pair<uint32_t, uint32_t>> again;
  Matcher(sensor, 0.6, false).SearchForTriangulation(*kf1, *kf2, F12, false, &again);
  for (const auto& [i1, i2] : again) EXPECT_NE(i1, pairs[0].first);
  // Only keypoints with depth: none here.
  EXPECT_EQ(Matcher(sensor, 0.6, false).SearchForTriangulation(*kf1, *kf2, F12, true, &again), 0);
}

TEST(FuseTest, MergesDuplicatesAndAddsObservations) {
  std::mt19937 rng(5);
  const SensorModel sensor = TestSensor();
  const std::vector<testing::ScenePoint> scene = RandomScene(50, rng);
  const testing::SyntheticView view = RenderView(sensor, scene, Rigid3d::Identity(), rng);
  Map map;
  KeyFrame* kf = map.CreateKeyFrame(MakeFrame(sensor, view, 0, Rigid3d::Identity()));
  KeyFrame* other = map.CreateKeyFrame(MakeFrame(sensor, view, 1, Rigid3d::Identity()));
  map.AddKeyFrame(kf);
  map.AddKeyFrame(other);

  // Keypoint 0 has map point A (seen by kf only); B duplicates A and is seen
  // by two keyframes' worth of observations: A is replaced by B.
  auto make_point = [&](size_t keypoint, std::vector<KeyFrame*> observers) {
    MapPoint* p = map.CreateMapPoint(scene[view.point_of[keypoint]].position, observers.front());
    for (KeyFrame* o : observers) map.AddObservation(p, o, static_cast<uint32_t>(keypoint));
    p->ComputeDistinctiveDescriptor();
    p->UpdateNormalAndDepth(sensor.pyramid);
    map.AddMapPoint(p);
    return p;
  };
  MapPoint* a = make_point(0, {kf});
  // B is observed by `other` only, then fused into kf.
  MapPoint* b = make_point(0, {other});
  map.AddObservation(b, other, 0);
  // C: a point at keypoint 1's position observed elsewhere; kf has no point there.
  MapPoint* c = make_point(1, {other});

  const int fused = Matcher(sensor, 0.6, true).Fuse(kf, {b, c}, &map);
  EXPECT_EQ(fused, 2);
  // A and B have the same weight (2 each): the point already in the keyframe
  // (A) is replaced by the incoming one (B), as ORB-SLAM2 does on ties.
  EXPECT_TRUE(a->bad());
  EXPECT_EQ(a->replaced_by(), b);
  EXPECT_EQ(kf->map_point(0), b);
  EXPECT_EQ(b->IndexIn(kf), 0);
  EXPECT_EQ(b->IndexIn(other), 0);
  EXPECT_EQ(kf->map_point(1), c);
  EXPECT_EQ(c->IndexIn(kf), 1);
  // A point already observed by the keyframe is skipped.
  EXPECT_EQ(Matcher(sensor, 0.6, true).Fuse(kf, {b, c}, &map), 0);
}

}  // namespace
}  // namespace rrslam
