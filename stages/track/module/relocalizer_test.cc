#include "stages/track/module/relocalizer.h"

#include <gtest/gtest.h>

#include <random>

#include "stages/track/data/map.h"
#include "stages/track/test_scene.h"

namespace rrslam {
namespace {

using testing::MakeFrame;
using testing::RandomScene;
using testing::RenderView;
using testing::SmallMotion;
using testing::TestSensor;
using testing::TranslationError;
using testing::ViewOptions;

TEST(SolvePnpRansacTest, RecoversThePoseWithHalfTheMatchesWrong) {
  std::mt19937 rng(3);
  const SensorModel sensor = TestSensor();
  const std::vector<testing::ScenePoint> scene = RandomScene(200, rng, 1.5, 4.0);
  const Rigid3d T_true = SmallMotion(0.3, 0.5);
  std::normal_distribution<double> noise(0.0, 0.5);
  std::uniform_real_distribution<double> ux(0, 640), uy(0, 480);
  std::vector<Eigen::Vector3d> points;
  std::vector<Eigen::Vector2d> pixels;
  std::vector<double> sigma2;
  std::vector<uint8_t> wrong;
  for (size_t i = 0; i < scene.size(); ++i) {
    const Eigen::Vector3d p = T_true * scene[i].position;
    if (p.z() <= 0.1) continue;
    Eigen::Vector2d px = sensor.Project(p) + Eigen::Vector2d(noise(rng), noise(rng));
    const bool outlier = points.size() % 2 == 1;  // Every second match.
    if (outlier) px = Eigen::Vector2d(ux(rng), uy(rng));
    points.push_back(scene[i].position);
    pixels.push_back(px);
    sigma2.push_back(1.0);
    wrong.push_back(outlier);
  }
  ASSERT_GT(points.size(), 100u);
  // Half inliers is ORB-SLAM2's minimum ratio: lower it a little so that an
  // outlier falling on its own point's projection cannot fail the test.
  PnpRansacOptions options;
  options.min_inlier_ratio = 0.4;
  const PnpResult r = SolvePnpRansac(points, pixels, sigma2, sensor.camera.K(), options, 7);
  ASSERT_TRUE(r.ok);
  EXPECT_LT(TranslationError(r.T_cam_world, T_true), 0.01);
  EXPECT_LT(RotationAngle(r.T_cam_world.rotation, T_true.rotation), 0.2 * M_PI / 180);
  int right_kept = 0, wrong_kept = 0;
  for (size_t i = 0; i < points.size(); ++i) (wrong[i] ? wrong_kept : right_kept) += r.inlier[i];
  const int n_wrong = static_cast<int>(std::count(wrong.begin(), wrong.end(), 1));
  EXPECT_GE(right_kept, 0.95 * (points.size() - n_wrong));
  EXPECT_LE(wrong_kept, 0.05 * n_wrong);
  // The same seed gives the same result.
  const PnpResult again = SolvePnpRansac(points, pixels, sigma2, sensor.camera.K(), options, 7);
  EXPECT_EQ(again.inlier, r.inlier);
}

TEST(SolvePnpRansacTest, FailsWithoutEnoughConsistentMatches) {
  std::mt19937 rng(4);
  const SensorModel sensor = TestSensor();
  std::uniform_real_distribution<double> ux(0, 640), uy(0, 480);
  const std::vector<testing::ScenePoint> scene = RandomScene(60, rng);
  std::vector<Eigen::Vector3d> points;
  std::vector<Eigen::Vector2d> pixels;
  for (const auto& p : scene) {
    points.push_back(p.position);
    pixels.emplace_back(ux(rng), uy(rng));  // No pose explains these.
  }
  const std::vector<double> sigma2(points.size(), 1.0);
  EXPECT_FALSE(SolvePnpRansac(points, pixels, sigma2, sensor.camera.K(), {}, 1).ok);
  EXPECT_FALSE(SolvePnpRansac({}, {}, {}, sensor.camera.K(), {}, 1).ok);
}

// A map of six keyframes along a short path over a random scene, indexed in
// a keyframe database; a frame seen from near keyframe 3, with noisy pixels,
// noisy descriptors and distractors, is relocalized without a pose guess.
class RelocalizerTest : public ::testing::Test {
 protected:
  void SetUp() override {
    scene_ = RandomScene(400, rng_, 2.0, 4.0);
    std::vector<MapPoint*> points(scene_.size(), nullptr);
    for (int k = 0; k < 6; ++k) {
      truth_.push_back(SmallMotion(0.03 * k, 0.1 * k));
      testing::SyntheticView view = RenderView(sensor_, scene_, truth_[k], rng_);
      KeyFrame* kf = map_.CreateKeyFrame(MakeFrame(sensor_, view, k, truth_[k]));
      map_.AddKeyFrame(kf);
      for (size_t i = 0; i < view.point_of.size(); ++i) {
        const int p = view.point_of[i];
        if (points[p] == nullptr) {
          points[p] = map_.CreateMapPoint(scene_[p].position, kf);
          map_.AddMapPoint(points[p]);
        }
        map_.AddObservation(points[p], kf, static_cast<uint32_t>(i));
      }
      keyframes_.push_back(kf);
    }
    for (MapPoint* p : points) {
      if (p == nullptr) continue;
      p->ComputeDistinctiveDescriptor();
      p->UpdateNormalAndDepth(sensor_.pyramid);
    }
    for (KeyFrame* kf : keyframes_) {
      map_.UpdateConnections(kf);
      kf->ComputeBow(vocabulary_, 4);
      database_.Add(kf);
    }
  }

  Frame QueryFrame(const std::vector<testing::ScenePoint>& scene, const Rigid3d& T) {
    ViewOptions options;
    options.pixel_noise = 0.5;
    options.flipped_bits = 8;
    options.distractors = 100;
    Frame frame =
        MakeFrame(sensor_, RenderView(sensor_, scene, T, rng_, options), 100, Rigid3d::Identity());
    frame.ComputeBow(vocabulary_, 4);
    return frame;
  }

  std::mt19937 rng_{17};
  SensorModel sensor_ = TestSensor();
  Vocabulary vocabulary_ = testing::HundredWordVocabulary();
  KeyFrameDatabase database_{vocabulary_};
  Map map_;
  std::vector<testing::ScenePoint> scene_;
  std::vector<Rigid3d> truth_;
  std::vector<KeyFrame*> keyframes_;
};

RelocalizationOptions WithMethod(RelocalizationMethod method) {
  RelocalizationOptions options;
  options.method = method;
  return options;
}

const RelocalizationMethod kMethods[] = {
    RelocalizationMethod::kBow, RelocalizationMethod::kBowDirect, RelocalizationMethod::kDirect};

TEST_F(RelocalizerTest, FindsTheFramesPoseInTheMap) {
  for (RelocalizationMethod method : kMethods) {
    SCOPED_TRACE(ToString(method));
    const Rigid3d T_true = SmallMotion(0.01, 0.03) * truth_[3];
    Frame frame = QueryFrame(scene_, T_true);
    Relocalizer relocalizer(sensor_, database_, map_, WithMethod(method));
    SolveCounts solves;
    RelocalizationAttempt attempt;
    KeyFrame* kf = relocalizer.Relocalize(&frame, &solves, &attempt);
    ASSERT_NE(kf, nullptr);
    EXPECT_LT(TranslationError(frame.T_cam_world(), T_true), 0.01);
    EXPECT_LT(RotationAngle(frame.T_cam_world().rotation, T_true.rotation), 0.2 * M_PI / 180);
    int matched = 0;
    for (MapPoint* p : frame.map_points) matched += p != nullptr;
    EXPECT_GE(matched, 50);
    EXPECT_EQ(attempt.inliers, matched);
    EXPECT_GT(solves.solves, 0u);
    // bow+direct stops at the BoW stage when it finds the pose.
    EXPECT_EQ(attempt.stage, method == RelocalizationMethod::kDirect ? "direct" : "bow");
    EXPECT_EQ(attempt.direct_matches > 0, method == RelocalizationMethod::kDirect);
  }
}

// With no keyframe on the shortlist (an empty database stands for a view the
// bag of words does not reach), only the direct stage finds the pose.
TEST_F(RelocalizerTest, TheDirectStageFindsWhatTheShortlistMisses) {
  const KeyFrameDatabase empty(vocabulary_);
  const Rigid3d T_true = SmallMotion(-0.01, 0.02) * truth_[2];
  Frame frame = QueryFrame(scene_, T_true);
  Relocalizer bow(sensor_, empty, map_, WithMethod(RelocalizationMethod::kBow));
  RelocalizationAttempt attempt;
  EXPECT_EQ(bow.Relocalize(&frame, nullptr, &attempt), nullptr);
  EXPECT_EQ(attempt.stage, "");
  EXPECT_EQ(attempt.bow_candidates, 0);

  Relocalizer both(sensor_, empty, map_, WithMethod(RelocalizationMethod::kBowDirect));
  ASSERT_NE(both.Relocalize(&frame, nullptr, &attempt), nullptr);
  EXPECT_EQ(attempt.stage, "direct");
  EXPECT_GE(attempt.direct_matches, 50);
  EXPECT_GE(attempt.inliers, 50);
  EXPECT_GT(attempt.index_ms, 0);
  EXPECT_LT(TranslationError(frame.T_cam_world(), T_true), 0.01);

  // The index is built once while the map stays as it is.
  Frame again = QueryFrame(scene_, T_true);
  ASSERT_NE(both.Relocalize(&again, nullptr, &attempt), nullptr);
  EXPECT_EQ(attempt.index_ms, 0);

  // A frame with a pose of its own (visual odometry) gets the BoW stage
  // alone under bow+direct; the direct method keeps its one stage.
  Frame tracked = QueryFrame(scene_, T_true);
  EXPECT_EQ(both.Relocalize(&tracked, nullptr, &attempt, true), nullptr);
  EXPECT_EQ(attempt.direct_queries, 0);
  Relocalizer direct(sensor_, empty, map_, WithMethod(RelocalizationMethod::kDirect));
  EXPECT_NE(direct.Relocalize(&tracked, nullptr, &attempt, true), nullptr);
  EXPECT_EQ(attempt.stage, "direct");
}

// A map just loaded: the index built in the background gives the direct
// stage the pose a build in place gives, and the attempt builds nothing.
TEST_F(RelocalizerTest, TheIndexBuiltInTheBackgroundGivesTheSamePose) {
  const KeyFrameDatabase empty(vocabulary_);
  const Rigid3d T_true = SmallMotion(0.015, -0.01) * truth_[1];
  Relocalizer in_place(sensor_, empty, map_, WithMethod(RelocalizationMethod::kBowDirect));
  Relocalizer background(sensor_, empty, map_, WithMethod(RelocalizationMethod::kBowDirect));
  background.PrepareIndexInBackground();
  Frame a = QueryFrame(scene_, T_true);
  Frame b = a;
  RelocalizationAttempt attempt_a, attempt_b;
  ASSERT_NE(in_place.Relocalize(&a, nullptr, &attempt_a), nullptr);
  ASSERT_NE(background.Relocalize(&b, nullptr, &attempt_b), nullptr);
  EXPECT_GT(attempt_a.index_ms, 0);
  EXPECT_GE(attempt_b.index_ms, 0);  // Only what it waited for the background build.
  EXPECT_GT(background.WaitForBackgroundIndex(), 0);
  EXPECT_EQ(attempt_a.inliers, attempt_b.inliers);
  EXPECT_EQ(a.T_cam_world().ToMatrix(), b.T_cam_world().ToMatrix());
  // Without a direct stage nothing is built.
  Relocalizer bow(sensor_, empty, map_, WithMethod(RelocalizationMethod::kBow));
  bow.PrepareIndexInBackground();
  EXPECT_EQ(bow.WaitForBackgroundIndex(), 0);
}

// A camera 30 degrees round the scene from every keyframe, looking at its
// middle: the direct stage matches its points wherever they were seen from.
TEST_F(RelocalizerTest, AViewThirtyDegreesFromEveryKeyFrame) {
  const Eigen::Vector3d centre(0, 0, 3);
  const Eigen::Matrix3d R_world_cam =
      Eigen::AngleAxisd(-35 * M_PI / 180, Eigen::Vector3d::UnitY()).toRotationMatrix();
  const Rigid3d T_world_cam(Eigen::Quaterniond(R_world_cam),
                            centre - R_world_cam * Eigen::Vector3d(0, 0, 3));
  const Rigid3d T_true = T_world_cam.Inverse();
  for (const Rigid3d& T : truth_) {
    ASSERT_GE(RotationAngle(T.rotation, T_true.rotation), 30 * M_PI / 180);
  }
  Frame frame = QueryFrame(scene_, T_true);
  Relocalizer relocalizer(sensor_, database_, map_, WithMethod(RelocalizationMethod::kDirect));
  ASSERT_NE(relocalizer.Relocalize(&frame), nullptr);
  EXPECT_LT(TranslationError(frame.T_cam_world(), T_true), 0.01);
  EXPECT_LT(RotationAngle(frame.T_cam_world().rotation, T_true.rotation), 0.2 * M_PI / 180);
}

// The direct stage's pose from a handful of matches is completed by its
// local map: 15 matches into the RANSAC, at least 50 inliers in the end.
TEST_F(RelocalizerTest, TheDirectStageCompletesAFewMatchesFromTheLocalMap) {
  RelocalizationOptions options = WithMethod(RelocalizationMethod::kDirect);
  options.direct.max_matches = 15;
  const Rigid3d T_true = SmallMotion(0.02, -0.02) * truth_[1];
  Frame frame = QueryFrame(scene_, T_true);
  Frame again = frame;
  Relocalizer relocalizer(sensor_, database_, map_, options);
  RelocalizationAttempt attempt;
  ASSERT_NE(relocalizer.Relocalize(&frame, nullptr, &attempt), nullptr);
  EXPECT_EQ(attempt.direct_matches, 15);
  EXPECT_GE(attempt.inliers, 50);
  EXPECT_LT(TranslationError(frame.T_cam_world(), T_true), 0.01);

  // Fewer verified inliers than asked for: no pose, and the attempt says
  // how many the pose had.
  options.min_inliers = attempt.inliers + 1;
  Relocalizer strict(sensor_, database_, map_, options);
  EXPECT_EQ(strict.Relocalize(&again, nullptr, &attempt), nullptr);
  EXPECT_EQ(attempt.stage, "");
  EXPECT_EQ(attempt.inliers, options.min_inliers - 1);
}

// Prioritised search: the strongest keypoints first; the rest only when
// their pose is not accepted.
TEST_F(RelocalizerTest, TheDirectStageSearchesTheRestOnlyWhenTheFirstKeypointsFail) {
  const Rigid3d T_true = SmallMotion(0.01, 0.02) * truth_[2];
  const Frame query = QueryFrame(scene_, T_true);
  const int keypoints = static_cast<int>(query.size());
  auto relocalize = [&](int first_queries, RelocalizationAttempt* attempt) {
    RelocalizationOptions options = WithMethod(RelocalizationMethod::kDirect);
    options.direct.first_queries = first_queries;
    Frame frame = query;
    Relocalizer relocalizer(sensor_, database_, map_, options);
    const bool ok = relocalizer.Relocalize(&frame, nullptr, attempt) != nullptr;
    if (ok) EXPECT_LT(TranslationError(frame.T_cam_world(), T_true), 0.01);
    return ok;
  };
  RelocalizationAttempt attempt;
  ASSERT_GT(keypoints, 200);
  EXPECT_TRUE(relocalize(200, &attempt));  // Enough in the first 200.
  EXPECT_EQ(attempt.direct_queries, 200);
  EXPECT_TRUE(relocalize(5, &attempt));  // 5 cannot give a pose: all searched.
  EXPECT_EQ(attempt.direct_queries, keypoints);
  EXPECT_GE(attempt.direct_matches, 50);
  EXPECT_TRUE(relocalize(0, &attempt));  // All at once.
  EXPECT_EQ(attempt.direct_queries, keypoints);
}

TEST_F(RelocalizerTest, AFrameOfAnotherPlaceIsNotRelocalized) {
  for (RelocalizationMethod method : kMethods) {
    SCOPED_TRACE(ToString(method));
    std::mt19937 other_rng(99);
    const std::vector<testing::ScenePoint> elsewhere = RandomScene(400, other_rng, 2.0, 4.0);
    Frame frame = QueryFrame(elsewhere, truth_[3]);
    Relocalizer relocalizer(sensor_, database_, map_, WithMethod(method));
    RelocalizationAttempt attempt;
    EXPECT_EQ(relocalizer.Relocalize(&frame, nullptr, &attempt), nullptr);
    EXPECT_EQ(attempt.stage, "");
    for (MapPoint* p : frame.map_points) EXPECT_EQ(p, nullptr);
  }
}

TEST(RelocalizationOptionsTest, MethodNamesRoundTripAndBadOptionsAreNamed) {
  for (RelocalizationMethod method : kMethods) {
    RelocalizationMethod parsed = RelocalizationMethod::kBow;
    ASSERT_TRUE(ParseRelocalizationMethod(ToString(method), &parsed));
    EXPECT_EQ(parsed, method);
  }
  RelocalizationMethod parsed;
  EXPECT_FALSE(ParseRelocalizationMethod("orb", &parsed));
  std::string why;
  EXPECT_TRUE(RelocalizationOptions{}.Check(&why));
  RelocalizationOptions options;
  options.direct.ratio = 1.5;
  EXPECT_FALSE(options.Check(&why));
  EXPECT_EQ(why, "direct.ratio = 1.500000; must be in (0, 1]");
  options = {};
  options.local_map.keyframes = 0;
  EXPECT_FALSE(options.Check(&why));
  EXPECT_EQ(why, "local_map.keyframes = 0; must be >= 1");
  options = {};
  options.bow_covisible = 21;
  EXPECT_FALSE(options.Check(&why));
  EXPECT_EQ(why, "bow_covisible = 21; must be in [0, 20]");
  options = {};
  options.direct.first_queries = -1;
  EXPECT_FALSE(options.Check(&why));
  EXPECT_EQ(why, "direct.first_queries = -1; must be >= 0");
}

// ORB-SLAM3's covisible window: each candidate's matches with those of its
// covisible keyframes find the pose as the candidate alone does.
TEST_F(RelocalizerTest, TheCovisibleWindowFindsThePose) {
  RelocalizationOptions options = WithMethod(RelocalizationMethod::kBow);
  options.bow_covisible = 3;
  const Rigid3d T_true = SmallMotion(0.01, 0.02) * truth_[2];
  Frame frame = QueryFrame(scene_, T_true);
  Relocalizer relocalizer(sensor_, database_, map_, options);
  RelocalizationAttempt attempt;
  ASSERT_NE(relocalizer.Relocalize(&frame, nullptr, &attempt), nullptr);
  EXPECT_EQ(attempt.stage, "bow");
  EXPECT_GE(attempt.inliers, 50);
  EXPECT_LT(TranslationError(frame.T_cam_world(), T_true), 0.01);
}

}  // namespace
}  // namespace rrslam
