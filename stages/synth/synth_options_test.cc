#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <limits>
#include <opencv2/core.hpp>

#include "common/errors.h"
#include "common/testing.h"
#include "stages/synth/scene.h"
#include "stages/synth/synth.h"

namespace rrslam {
namespace {

TEST(SynthOptions, DefaultsPassCheck) {
  std::string why;
  EXPECT_TRUE(SynthOptions().Check(&why)) << why;
}

TEST(SynthOptions, EachConstraintFails) {
  struct Case {
    std::string name;  // Expected at the start of the message.
    std::function<void(SynthOptions&)> change;
  };
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const std::vector<Case> cases = {
      {"frames", [](SynthOptions& o) { o.frames = 0; }},
      {"frames", [](SynthOptions& o) { o.frames = 100001; }},
      {"fps", [](SynthOptions& o) { o.fps = 0; }},
      {"fps", [](SynthOptions& o) { o.fps = 1001; }},
      {"fps", [nan](SynthOptions& o) { o.fps = nan; }},
      {"width", [](SynthOptions& o) { o.width = 15; }},
      {"width", [](SynthOptions& o) { o.width = 8193; }},
      {"height", [](SynthOptions& o) { o.height = 15; }},
      {"height", [](SynthOptions& o) { o.height = 8193; }},
      {"fx", [](SynthOptions& o) { o.fx = 0.5; }},
      {"fx", [](SynthOptions& o) { o.fx = -525; }},
      {"fy", [](SynthOptions& o) { o.fy = 2e5; }},
      {"cx", [](SynthOptions& o) { o.cx = -1; }},
      {"cx", [](SynthOptions& o) { o.cx = 639.5; }},
      {"cy", [](SynthOptions& o) { o.cy = 480; }},
      {"cy", [nan](SynthOptions& o) { o.cy = nan; }},
      {"depth_noise", [](SynthOptions& o) { o.depth_noise = -1e-3; }},
      {"depth_noise", [](SynthOptions& o) { o.depth_noise = 0.06; }},
      {"depth_holes", [](SynthOptions& o) { o.depth_holes = -0.1; }},
      {"depth_holes", [](SynthOptions& o) { o.depth_holes = 0.95; }},
      {"depth_scale_error", [](SynthOptions& o) { o.depth_scale_error = 0.5; }},
      {"depth_scale_error", [](SynthOptions& o) { o.depth_scale_error = -0.5; }},
      {"depth_scale_error", [](SynthOptions& o) { o.depth_scale_error = 2; }},
      {"depth_scale_error", [nan](SynthOptions& o) { o.depth_scale_error = nan; }},
      {"depth_scale_wander", [](SynthOptions& o) { o.depth_scale_wander = -0.01; }},
      {"depth_scale_wander", [](SynthOptions& o) { o.depth_scale_wander = 0.3; }},
      {"depth_scale_wander", [nan](SynthOptions& o) { o.depth_scale_wander = nan; }},
      {"depth_scale_wander",
       [](SynthOptions& o) {
         o.depth_scale_error = -0.4;
         o.depth_scale_wander = 0.1;
       }},
      {"depth_scale_period", [](SynthOptions& o) { o.depth_scale_period = 0; }},
      {"depth_scale_period", [](SynthOptions& o) { o.depth_scale_period = 4000; }},
      {"depth_scale_period", [nan](SynthOptions& o) { o.depth_scale_period = nan; }},
      {"brightness_change", [](SynthOptions& o) { o.brightness_change = 1.0; }},
      {"brightness_change", [](SynthOptions& o) { o.brightness_change = -0.1; }},
      {"motion_blur", [](SynthOptions& o) { o.motion_blur = -1; }},
      {"motion_blur", [](SynthOptions& o) { o.motion_blur = 65; }},
      {"texel_size", [](SynthOptions& o) { o.texel_size = 0; }},
      {"texel_size", [](SynthOptions& o) { o.texel_size = 0.1; }},
      {"threads", [](SynthOptions& o) { o.threads = -1; }},
      {"threads", [](SynthOptions& o) { o.threads = 257; }},
      {"scene_change", [](SynthOptions& o) { o.scene_change = "foo"; }},
      {"scene_change", [](SynthOptions& o) { o.scene_change = ""; }},
      {"scene_change", [](SynthOptions& o) { o.scene_change = "Moved-Box"; }},
      {"scene_change",
       [](SynthOptions& o) {
         o.scene = synth::SceneKind::kBuilding;
         o.trajectory = synth::TrajectoryKind::kTour;
         o.scene_change = "moved-box";
       }},
      {"trajectory", [](SynthOptions& o) { o.scene = synth::SceneKind::kBuilding; }},
      {"trajectory", [](SynthOptions& o) { o.trajectory = synth::TrajectoryKind::kTour; }},
  };
  for (const Case& c : cases) {
    SynthOptions options;
    c.change(options);
    std::string why;
    EXPECT_FALSE(options.Check(&why)) << c.name;
    EXPECT_EQ(why.rfind(c.name + " = ", 0), 0u) << "message: " << why;
    EXPECT_NE(why.find("must be"), std::string::npos) << why;
  }
}

TEST(SynthOptions, BoundaryValuesPass) {
  SynthOptions o;
  o.frames = 1;
  o.width = 16;
  o.height = 16;
  o.cx = 15;
  o.cy = 7.5;
  o.fx = 1;
  o.depth_noise = 0;
  o.depth_holes = 0;
  o.depth_scale_error = 0.299;
  o.depth_scale_wander = 0.2;
  o.depth_scale_period = 0.1;
  o.motion_blur = 64;
  o.brightness_change = 0.9;
  o.threads = 256;
  std::string why;
  EXPECT_TRUE(o.Check(&why)) << why;
}

TEST(SynthOptions, DefaultIntrinsicsScaleWithImageSize) {
  SynthOptions o;
  PinholeCamera camera = o.Camera();
  EXPECT_DOUBLE_EQ(camera.fx(), 525.0);
  EXPECT_DOUBLE_EQ(camera.fy(), 525.0);
  EXPECT_DOUBLE_EQ(camera.cx(), 319.5);
  EXPECT_DOUBLE_EQ(camera.cy(), 239.5);
  EXPECT_EQ(camera.width(), 640);
  EXPECT_EQ(camera.height(), 480);
  EXPECT_TRUE(camera.distortion().IsZero());

  // Half the size: the same field of view, pixel centres kept aligned.
  o.width = 320;
  o.height = 240;
  camera = o.Camera();
  EXPECT_DOUBLE_EQ(camera.fx(), 262.5);
  EXPECT_DOUBLE_EQ(camera.fy(), 262.5);
  EXPECT_DOUBLE_EQ(camera.cx(), 159.5);
  EXPECT_DOUBLE_EQ(camera.cy(), 119.5);

  // Given values are kept.
  o.fx = 500;
  o.cy = 100;
  camera = o.Camera();
  EXPECT_DOUBLE_EQ(camera.fx(), 500.0);
  EXPECT_DOUBLE_EQ(camera.fy(), 262.5);
  EXPECT_DOUBLE_EQ(camera.cy(), 100.0);
}

TEST(SynthOptions, SettingsMatchTheRendering) {
  SynthOptions o;
  Settings s = o.MakeSettings();
  std::string why;
  EXPECT_TRUE(s.Check(&why)) << why;
  EXPECT_DOUBLE_EQ(s.fx, 525.0);
  EXPECT_DOUBLE_EQ(s.cy, 239.5);
  EXPECT_EQ(s.width, 640);
  EXPECT_EQ(s.height, 480);
  EXPECT_DOUBLE_EQ(s.bf, 40.0);
  EXPECT_DOUBLE_EQ(s.th_depth, 40.0);
  EXPECT_DOUBLE_EQ(s.depth_map_factor, 5000.0);
  EXPECT_DOUBLE_EQ(s.fps, 30.0);
  // Disparity noise: bf * k of the Kinect model (0.057 px) with the 0.1 px
  // of reading depth at a keypoint.
  EXPECT_EQ(s.depth_noise.model, DepthNoise::Model::kQuadratic);
  EXPECT_DOUBLE_EQ(s.depth_noise.k2, 1.425e-3);
  EXPECT_NEAR(s.depth_noise.DisparitySigma(s.bf), std::hypot(40.0 * 1.425e-3, 0.1), 1e-12);
  o.depth_noise = 0;
  EXPECT_DOUBLE_EQ(o.MakeSettings().depth_noise.DisparitySigma(40.0), 0.1);
  o.depth_noise = 1.425e-3;
  EXPECT_TRUE(s.distortion.IsZero());
  EXPECT_EQ(s.orb.n_features, 1000);
  EXPECT_EQ(s.orb.n_levels, 8);
  EXPECT_DOUBLE_EQ(s.orb.scale_factor, 1.2);
  EXPECT_EQ(s.orb.ini_th_fast, 20);
  EXPECT_EQ(s.orb.min_th_fast, 7);

  // The virtual baseline (bf / fx) does not change with the image size.
  o.width = 320;
  o.height = 240;
  s = o.MakeSettings();
  EXPECT_NEAR(s.Baseline(), 40.0 / 525.0, 1e-12);
  EXPECT_NEAR(s.ThDepthMetres(), 40.0 * 40.0 / 525.0, 1e-12);
}

TEST(SynthOptions, JsonRecordsResolvedOptions) {
  SynthOptions o;
  o.seed = 7;
  o.trajectory = synth::TrajectoryKind::kSweep;
  const std::string json = o.ToJson();
  EXPECT_NE(json.find("\"trajectory\":\"sweep\""), std::string::npos) << json;
  EXPECT_NE(json.find("\"seed\":7"), std::string::npos) << json;
  EXPECT_NE(json.find("\"fx\":525.0"), std::string::npos) << json;
  EXPECT_EQ(json.find("threads"), std::string::npos) << "threads do not change the output";
}

TEST(SynthOptions, DepthScaleError) {
  SynthOptions o;
  EXPECT_EQ(o.depth_scale_error, 0.0);  // Calibrated by default.
  EXPECT_NE(o.ToJson().find("\"depth_scale_error\":0.0"), std::string::npos) << o.ToJson();
  std::string why;
  for (double e : {-0.499, -0.01, 0.01, 0.499}) {
    o.depth_scale_error = e;
    EXPECT_TRUE(o.Check(&why)) << e << ": " << why;
  }
  o.depth_scale_error = 0.01;
  EXPECT_NE(o.ToJson().find("\"depth_scale_error\":0.01"), std::string::npos) << o.ToJson();
  // The sensor's bias is not known to the settings: they stay those of E = 0.
  EXPECT_DOUBLE_EQ(o.MakeSettings().depth_map_factor, 5000.0);
  EXPECT_DOUBLE_EQ(o.MakeSettings().depth_noise.k2, SynthOptions().MakeSettings().depth_noise.k2);
  // Out of range: one line naming the option and its value.
  o.depth_scale_error = 0.6;
  EXPECT_FALSE(o.Check(&why));
  EXPECT_EQ(why, "depth_scale_error = 0.6; must be in (-0.5, 0.5)");
  o.depth_scale_error = -0.5;
  EXPECT_FALSE(o.Check(&why));
  EXPECT_EQ(why, "depth_scale_error = -0.5; must be in (-0.5, 0.5)");
  EXPECT_THROW(SyntheticSequence sequence(o), UsageError);
}

TEST(SynthOptions, DepthScaleWander) {
  SynthOptions o;
  EXPECT_EQ(o.depth_scale_wander, 0.0);  // A constant bias by default.
  o.depth_scale_error = 0.01;
  for (double t : {0.0, 1.0, 7.3}) EXPECT_EQ(o.DepthScaleError(t), 0.01);
  o.depth_scale_wander = 0.02;
  o.depth_scale_period = 8;
  EXPECT_DOUBLE_EQ(o.DepthScaleError(0), 0.01);
  EXPECT_DOUBLE_EQ(o.DepthScaleError(2), 0.03);   // A quarter period: the peak.
  EXPECT_DOUBLE_EQ(o.DepthScaleError(6), -0.01);  // Three quarters: the trough.
  EXPECT_NE(o.ToJson().find("\"depth_scale_wander\":0.02,\"depth_scale_period\":8.0"),
            std::string::npos)
      << o.ToJson();

  // The rendered depth follows it: frame i of a tiny sequence at 1 fps
  // against the same frame with the bias held at its value then.
  o = SynthOptions();
  o.width = 64;
  o.height = 48;
  o.frames = 3;
  o.fps = 1;
  o.depth_noise = 0;
  o.depth_holes = 0;
  o.depth_scale_wander = 0.05;
  o.depth_scale_period = 4;
  o.texel_size = 0.02;  // Coarse textures: a quick room.
  o.threads = 1;
  const SyntheticSequence wandering(o);
  for (size_t i = 0; i < 3; ++i) {
    SynthOptions fixed = o;
    fixed.depth_scale_wander = 0;
    fixed.depth_scale_error = o.DepthScaleError(static_cast<double>(i));
    const SyntheticSequence held(fixed);
    const cv::Mat a = wandering.Render(i).depth, b = held.Render(i).depth;
    EXPECT_EQ(cv::countNonZero(a != b), 0) << "frame " << i;
  }
  // And the bias does change the depth between frames 0 (E = 0) and 1 (E = 0.05).
  SynthOptions calibrated = o;
  calibrated.depth_scale_wander = 0;
  const SyntheticSequence exact(calibrated);
  EXPECT_EQ(cv::countNonZero(wandering.Render(0).depth != exact.Render(0).depth), 0);
  EXPECT_GT(cv::countNonZero(wandering.Render(1).depth != exact.Render(1).depth), 0);
}

TEST(SynthOptions, RunSynthRejectsBadOptionsAndWritesNothing) {
  testing::TempDir dir;
  SynthOptions o;
  o.out = dir / "seq";
  o.frames = 0;
  EXPECT_THROW(RunSynth(o), UsageError);
  o.frames = 3;
  o.out.clear();
  EXPECT_THROW(RunSynth(o), UsageError);
  EXPECT_TRUE(std::filesystem::is_empty(dir.path()));
  // The in-memory sequence checks its options too.
  o.width = 4;
  EXPECT_THROW(SyntheticSequence sequence(o), UsageError);
}

TEST(SynthOptions, ShakeHasMotionBlurAndDepthNoiseUnlessSetOtherwise) {
  SynthOptions o;
  EXPECT_FALSE(o.motion_blur.has_value());
  EXPECT_EQ(o.MotionBlur(), 0.0);  // Loop, sweep and rotation: sharp by default.
  o.trajectory = synth::TrajectoryKind::kShake;
  EXPECT_EQ(o.MotionBlur(), kShakeMotionBlur);
  EXPECT_GT(kShakeMotionBlur, 0.0);
  EXPECT_DOUBLE_EQ(o.depth_noise, 1.425e-3);  // The Kinect's, for every trajectory.
  std::string why;
  EXPECT_TRUE(o.Check(&why)) << why;
  // The resolved blur is what the sidecar records.
  EXPECT_NE(o.ToJson().find("\"motion_blur\":8.0"), std::string::npos) << o.ToJson();

  // A value set explicitly wins, 0 (no blur) included.
  o.motion_blur = 0;
  EXPECT_EQ(o.MotionBlur(), 0.0);
  EXPECT_NE(o.ToJson().find("\"motion_blur\":0.0"), std::string::npos) << o.ToJson();
  o.motion_blur = 3;
  EXPECT_EQ(o.MotionBlur(), 3.0);
  o.trajectory = synth::TrajectoryKind::kLoop;
  EXPECT_EQ(o.MotionBlur(), 3.0);
  o.depth_noise = 0;
  o.trajectory = synth::TrajectoryKind::kShake;
  EXPECT_EQ(o.depth_noise, 0.0);

  EXPECT_EQ(DefaultMotionBlur(synth::TrajectoryKind::kLoop), 0.0);
  EXPECT_EQ(DefaultMotionBlur(synth::TrajectoryKind::kSweep), 0.0);
  EXPECT_EQ(DefaultMotionBlur(synth::TrajectoryKind::kRotation), 0.0);
  EXPECT_EQ(DefaultMotionBlur(synth::TrajectoryKind::kShake), kShakeMotionBlur);
}

TEST(SynthOptions, SceneChange) {
  SynthOptions o;
  EXPECT_EQ(o.scene_change, "none");  // The standard room by default.
  EXPECT_NE(o.ToJson().find("\"scene_change\":\"none\""), std::string::npos) << o.ToJson();
  std::string why;
  o.scene_change = "moved-box";
  EXPECT_TRUE(o.Check(&why)) << why;
  EXPECT_NE(o.ToJson().find("\"scene_change\":\"moved-box\""), std::string::npos) << o.ToJson();
  // Unknown names: one line naming the option, its value and the valid names.
  o.scene_change = "foo";
  EXPECT_FALSE(o.Check(&why));
  EXPECT_EQ(why, "scene_change = foo; must be none or moved-box");
  EXPECT_THROW(SyntheticSequence sequence(o), UsageError);
  // Names round-trip.
  for (auto change : {synth::SceneChange::kNone, synth::SceneChange::kMovedBox}) {
    synth::SceneChange parsed = synth::SceneChange::kNone;
    ASSERT_TRUE(synth::ParseSceneChange(synth::SceneChangeName(change), &parsed));
    EXPECT_EQ(parsed, change);
  }
  EXPECT_EQ(synth::SceneChangeName(synth::SceneChange::kMovedBox), "moved-box");
}

// The building is walked by the tour only, and has no scene changes; the
// tour walks only the building. Each wrong pair is one line naming both
// options.
TEST(SynthOptions, SceneAndTrajectoryGoTogether) {
  SynthOptions o;
  EXPECT_EQ(o.scene, synth::SceneKind::kStandard);  // The standard room by default.
  EXPECT_NE(o.ToJson().find("\"scene\":\"standard\",\"trajectory\":\"loop\""), std::string::npos)
      << o.ToJson();
  std::string why;
  o.scene = synth::SceneKind::kBuilding;
  o.trajectory = synth::TrajectoryKind::kTour;
  EXPECT_TRUE(o.Check(&why)) << why;
  EXPECT_NE(o.ToJson().find("\"scene\":\"building\",\"trajectory\":\"tour\""), std::string::npos)
      << o.ToJson();
  EXPECT_EQ(o.MotionBlur(), 0.0);  // Sharp, as the other walks.

  o.scene_change = "moved-box";
  EXPECT_FALSE(o.Check(&why));
  EXPECT_EQ(why,
            "scene_change = moved-box; must be none with scene = building (--change moved-box "
            "edits the standard room, not --scene building)");
  EXPECT_THROW(SyntheticSequence sequence(o), UsageError);
  o.scene_change = "none";
  for (auto kind : {synth::TrajectoryKind::kLoop, synth::TrajectoryKind::kSweep,
                    synth::TrajectoryKind::kRotation, synth::TrajectoryKind::kShake,
                    synth::TrajectoryKind::kTurn}) {
    o.trajectory = kind;
    EXPECT_FALSE(o.Check(&why)) << synth::TrajectoryKindName(kind);
    EXPECT_EQ(why, "trajectory = " + synth::TrajectoryKindName(kind) +
                       "; must be tour with scene = building (--scene building is walked by "
                       "--trajectory tour only)");
  }
  o.scene = synth::SceneKind::kStandard;
  o.trajectory = synth::TrajectoryKind::kTour;
  EXPECT_FALSE(o.Check(&why));
  EXPECT_EQ(why,
            "trajectory = tour; must be loop, sweep, rotation, shake or turn with scene = standard "
            "(--trajectory tour needs --scene building)");
  EXPECT_THROW(SyntheticSequence sequence(o), UsageError);

  for (auto kind : {synth::SceneKind::kStandard, synth::SceneKind::kBuilding}) {
    synth::SceneKind parsed = synth::SceneKind::kStandard;
    ASSERT_TRUE(synth::ParseSceneKind(synth::SceneKindName(kind), &parsed));
    EXPECT_EQ(parsed, kind);
  }
  synth::SceneKind parsed;
  EXPECT_FALSE(synth::ParseSceneKind("house", &parsed));
}

TEST(SynthOptions, TrajectoryNamesRoundTrip) {
  EXPECT_EQ(synth::TrajectoryKindName(synth::TrajectoryKind::kShake), "shake");
  EXPECT_EQ(synth::TrajectoryKindName(synth::TrajectoryKind::kTour), "tour");
  for (auto kind : {synth::TrajectoryKind::kLoop, synth::TrajectoryKind::kSweep,
                    synth::TrajectoryKind::kRotation, synth::TrajectoryKind::kShake,
                    synth::TrajectoryKind::kTurn, synth::TrajectoryKind::kTour}) {
    synth::TrajectoryKind parsed = synth::TrajectoryKind::kLoop;
    ASSERT_TRUE(synth::ParseTrajectoryKind(synth::TrajectoryKindName(kind), &parsed));
    EXPECT_EQ(parsed, kind);
  }
  synth::TrajectoryKind parsed;
  EXPECT_FALSE(synth::ParseTrajectoryKind("circle", &parsed));
}

}  // namespace
}  // namespace rrslam
