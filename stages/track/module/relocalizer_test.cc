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

TEST_F(RelocalizerTest, FindsTheFramesPoseInTheMap) {
  const Rigid3d T_true = SmallMotion(0.01, 0.03) * truth_[3];
  Frame frame = QueryFrame(scene_, T_true);
  const Relocalizer relocalizer(sensor_, database_);
  SolveCounts solves;
  KeyFrame* kf = relocalizer.Relocalize(&frame, &solves);
  ASSERT_NE(kf, nullptr);
  EXPECT_LT(TranslationError(frame.T_cam_world(), T_true), 0.01);
  EXPECT_LT(RotationAngle(frame.T_cam_world().rotation, T_true.rotation), 0.2 * M_PI / 180);
  int matched = 0;
  for (MapPoint* p : frame.map_points) matched += p != nullptr;
  EXPECT_GE(matched, 50);
  EXPECT_GT(solves.solves, 0u);
}

TEST_F(RelocalizerTest, AFrameOfAnotherPlaceIsNotRelocalized) {
  std::mt19937 other_rng(99);
  const std::vector<testing::ScenePoint> elsewhere = RandomScene(400, other_rng, 2.0, 4.0);
  Frame frame = QueryFrame(elsewhere, truth_[3]);
  const Relocalizer relocalizer(sensor_, database_);
  EXPECT_EQ(relocalizer.Relocalize(&frame), nullptr);
  for (MapPoint* p : frame.map_points) EXPECT_EQ(p, nullptr);
}

}  // namespace
}  // namespace rrslam
