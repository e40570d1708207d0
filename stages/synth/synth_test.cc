#include "stages/synth/synth.h"

#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>
#include <opencv2/imgproc.hpp>

#include "common/atomic_file.h"
#include "common/cli.h"
#include "common/dataset.h"
#include "common/errors.h"
#include "common/settings.h"
#include "common/testing.h"
#include "common/text.h"
#include "stages/synth/renderer.h"
#include "stages/synth/scene.h"

namespace rrslam {
namespace {
namespace fs = std::filesystem;

// A small, fast sequence: 160 x 120, coarse textures.
SynthOptions SmallOptions(const fs::path& out) {
  SynthOptions o;
  o.out = out;
  o.frames = 5;
  o.width = 160;
  o.height = 120;
  o.texel_size = 0.008;
  o.threads = 2;
  return o;
}

std::vector<std::string> Lines(const fs::path& path) {
  std::ifstream in(path);
  std::vector<std::string> lines;
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

// Every file below `dir`, relative path -> content.
std::map<std::string, std::string> Contents(const fs::path& dir) {
  std::map<std::string, std::string> files;
  for (const auto& entry : fs::recursive_directory_iterator(dir)) {
    if (entry.is_regular_file()) {
      files[fs::relative(entry.path(), dir).string()] = ReadFileToString(entry.path());
    }
  }
  return files;
}

TEST(RunSynth, WritesATumSequenceThatTheReadersAccept) {
  testing::TempDir dir;
  SynthOptions o = SmallOptions(dir / "seq");
  o.trajectory = synth::TrajectoryKind::kSweep;
  RunSynth(o);
  EXPECT_EQ(testing::TemporaryLeftovers(dir), std::vector<std::string>{});

  // Lists: three '#' header lines, then `timestamp path`.
  const auto rgb = Lines(dir / "seq" / "rgb.txt");
  ASSERT_EQ(rgb.size(), 3u + 5u);
  for (int i = 0; i < 3; ++i) EXPECT_EQ(rgb[i][0], '#');
  EXPECT_EQ(rgb[3], "0.000000 rgb/0.000000.png");
  EXPECT_EQ(rgb[4], "0.033333 rgb/0.033333.png");
  EXPECT_EQ(Lines(dir / "seq" / "depth.txt")[4], "0.033333 depth/0.033333.png");
  const auto associations = Lines(dir / "seq" / "associations.txt");
  ASSERT_EQ(associations.size(), 5u);
  EXPECT_EQ(associations[1], "0.033333 rgb/0.033333.png 0.033333 depth/0.033333.png");

  // The sequence reader pairs all frames and loads the images.
  const RgbdSequence sequence = RgbdSequence::Open(dir / "seq");
  ASSERT_EQ(sequence.size(), 5u);
  const cv::Mat color = sequence.LoadColor(2);
  EXPECT_EQ(color.size(), cv::Size(160, 120));
  EXPECT_EQ(color.type(), CV_8UC3);
  const cv::Mat depth = sequence.LoadDepthRaw(2);
  EXPECT_EQ(depth.type(), CV_16UC1);
  EXPECT_EQ(depth.size(), cv::Size(160, 120));
  const cv::Mat metres = sequence.LoadDepthMetres(2, 5000.0);
  double min_depth, max_depth;
  cv::minMaxLoc(metres, &min_depth, &max_depth, nullptr, nullptr, metres > 0);
  EXPECT_GT(min_depth, 0.5);
  EXPECT_LT(max_depth, 8.5);
  const double valid = static_cast<double>(cv::countNonZero(metres > 0)) / metres.total();
  EXPECT_GT(valid, 0.9);
  EXPECT_LT(valid, 1.0);  // Default holes.

  // Ground truth at the frame timestamps, equal to the in-memory sequence.
  ASSERT_TRUE(sequence.groundtruth().has_value());
  const Trajectory& gt = *sequence.groundtruth();
  ASSERT_EQ(gt.size(), 5u);
  const Trajectory expected = synth::MakeTrajectory(o.trajectory, 5, 30.0);
  for (size_t i = 0; i < gt.size(); ++i) {
    EXPECT_DOUBLE_EQ(gt[i].timestamp, sequence.frame(i).rgb_timestamp);
    EXPECT_LT((gt[i].T_world_cam.translation - expected[i].T_world_cam.translation).norm(), 1e-8);
    EXPECT_LT(RotationAngle(gt[i].T_world_cam.rotation, expected[i].T_world_cam.rotation), 1e-8);
  }

  // Settings match the rendering camera.
  const Settings settings = ReadSettings(dir / "seq" / "settings.yaml");
  EXPECT_DOUBLE_EQ(settings.fx, 131.25);
  EXPECT_DOUBLE_EQ(settings.cx, 79.5);
  EXPECT_EQ(settings.width, 160);
  EXPECT_DOUBLE_EQ(settings.depth_map_factor, 5000.0);
  EXPECT_NEAR(settings.Baseline(), 40.0 / 525.0, 1e-9);

  // The sidecar records producer and options.
  const auto info = nlohmann::json::parse(ReadFileToString(dir / "seq" / "synth.json"));
  EXPECT_EQ(info["producer"], Producer("synth"));
  EXPECT_EQ(info["options"]["trajectory"], "sweep");
  EXPECT_EQ(info["options"]["frames"], 5);
  EXPECT_EQ(info["options"]["seed"], 0);
  EXPECT_DOUBLE_EQ(info["options"]["depth_noise"].get<double>(), 1.425e-3);
  EXPECT_DOUBLE_EQ(info["options"]["depth_scale_error"].get<double>(), 0.0);
}

TEST(RunSynth, NoiseFreeDepthReprojectsToTheSceneWithinAMillimetre) {
  testing::TempDir dir;
  SynthOptions o = SmallOptions(dir / "seq");
  o.depth_noise = 0;
  o.depth_holes = 0;
  o.frames = 3;
  RunSynth(o);
  const RgbdSequence sequence = RgbdSequence::Open(dir / "seq");
  const SyntheticSequence in_memory(o);  // Same scene geometry for ray casting.
  // The camera as a SLAM system would see it: from the written settings.
  const PinholeCamera camera = ReadSettings(dir / "seq" / "settings.yaml").Camera();
  for (size_t i = 0; i < sequence.size(); ++i) {
    const cv::Mat metres = sequence.LoadDepthMetres(i, 5000.0);
    const Rigid3d& T_world_cam = (*sequence.groundtruth())[i].T_world_cam;
    // 16-bit depth in steps of 0.2 mm: at most 0.1 mm along z, a little more
    // along oblique rays. Worst distances to the ray-cast point and to the
    // plane of the surface hit:
    double worst_point = 0, worst_plane = 0;
    for (int v = 0; v < metres.rows; ++v) {
      for (int u = 0; u < metres.cols; ++u) {
        const double z = metres.at<float>(v, u);
        ASSERT_GT(z, 0.0);
        const Eigen::Vector3d point_world =
            T_world_cam * camera.Unproject(Eigen::Vector2d(u, v), z);
        const auto hit = in_memory.scene().RayCast(
            T_world_cam.translation,
            T_world_cam.rotation * camera.Unproject(Eigen::Vector2d(u, v), 1.0));
        ASSERT_TRUE(hit.has_value());
        worst_point = std::max(worst_point, (point_world - hit->point_world).norm());
        worst_plane = std::max(
            worst_plane,
            std::fabs(in_memory.scene().surface(hit->surface_id).PlaneDistance(point_world)));
      }
    }
    EXPECT_LT(worst_point, 1e-3) << "frame " << i;
    EXPECT_LT(worst_plane, 1e-3) << "frame " << i;
  }
}

// The images, depth, intrinsics and ground truth agree to a fraction of a
// pixel: warping a later frame into the first one through the first frame's
// depth and the ground-truth relative pose (all read back from the written
// files) matches the first frame better than the same warp shifted by a
// quarter pixel in any direction.
TEST(RunSynth, GroundTruthAlignsTheImagesToSubpixelAccuracy) {
  testing::TempDir dir;
  SynthOptions o = SmallOptions(dir / "seq");
  o.width = 320;
  o.height = 240;
  o.frames = 30;
  o.texel_size = 0.004;
  o.depth_noise = 0;
  o.depth_holes = 0;
  for (auto [kind, j] : {std::pair{synth::TrajectoryKind::kLoop, 15},
                         std::pair{synth::TrajectoryKind::kRotation, 7}}) {
    o.trajectory = kind;
    RunSynth(o);
    const RgbdSequence sequence = RgbdSequence::Open(dir / "seq");
    const Settings settings = ReadSettings(dir / "seq" / "settings.yaml");
    const PinholeCamera camera = settings.Camera();
    cv::Mat gray0, gray_j;
    sequence.LoadGray(0).convertTo(gray0, CV_32F);
    sequence.LoadGray(j).convertTo(gray_j, CV_32F);
    const cv::Mat depth0 = sequence.LoadDepthMetres(0, settings.depth_map_factor);
    const Trajectory& gt = *sequence.groundtruth();
    const Rigid3d T_j_0 = gt[j].T_world_cam.Inverse() * gt[0].T_world_cam;
    ASSERT_GT(RotationAngle(T_j_0.rotation, Eigen::Quaterniond::Identity()), 0.01);  // Moved.
    cv::Mat map_u(o.height, o.width, CV_32F), map_v(o.height, o.width, CV_32F);
    for (int v = 0; v < o.height; ++v) {
      for (int u = 0; u < o.width; ++u) {
        const Eigen::Vector2d p =
            camera.Project(T_j_0 * camera.Unproject(Eigen::Vector2d(u, v), depth0.at<float>(v, u)));
        map_u.at<float>(v, u) = static_cast<float>(p.x());
        map_v.at<float>(v, u) = static_cast<float>(p.y());
      }
    }
    auto warp_error = [&](float du, float dv) {
      cv::Mat warped;
      cv::remap(gray_j, warped, map_u + du, map_v + dv, cv::INTER_LINEAR, cv::BORDER_CONSTANT,
                cv::Scalar(-1));
      const cv::Mat valid = warped >= 0;
      return cv::mean(cv::abs(warped - gray0), valid)[0];
    };
    const double aligned = warp_error(0, 0);
    for (auto [du, dv] : {std::pair{0.25f, 0.0f}, std::pair{-0.25f, 0.0f}, std::pair{0.0f, 0.25f},
                          std::pair{0.0f, -0.25f}}) {
      EXPECT_LT(aligned * 1.1, warp_error(du, dv))
          << synth::TrajectoryKindName(kind) << " shift " << du << ", " << dv;
    }
  }
}

// Renders `o` into dir/a with every core and into dir/b on one thread, checks
// the files are byte-identical and returns them.
std::map<std::string, std::string> RenderTwiceWithOtherThreads(SynthOptions o,
                                                               const fs::path& dir) {
  o.out = dir / "a";
  RunSynth(o);
  o.out = dir / "b";
  o.threads = 1;
  RunSynth(o);
  const auto a = Contents(dir / "a"), b = Contents(dir / "b");
  EXPECT_EQ(a.size(), 2u * 5u + 7u);  // Images, lists, settings, synth.json, .rrslam-output.
  EXPECT_TRUE(a == b);
  return a;
}

TEST(RunSynth, SameOptionsGiveByteIdenticalFilesWhateverTheThreads) {
  testing::TempDir dir;
  SynthOptions o = SmallOptions(dir / "a");
  o.brightness_change = 0.2;
  o.motion_blur = 2;
  const auto a = RenderTwiceWithOtherThreads(o, dir.path());

  // Another seed: every image differs (textures, noise and holes), while the
  // ground truth stays the same.
  o.out = dir / "c";
  o.seed = 1;
  RunSynth(o);
  const auto c = Contents(dir / "c");
  for (const auto& [name, content] : a) {
    if (name.rfind("rgb/", 0) == 0 || name.rfind("depth/", 0) == 0) {
      EXPECT_NE(content, c.at(name)) << name;
    }
  }
  EXPECT_EQ(a.at("groundtruth.txt"), c.at("groundtruth.txt"));
  EXPECT_NE(a.at("synth.json"), c.at("synth.json"));
}

TEST(RunSynth, ShakeGivesByteIdenticalFilesWhateverTheThreads) {
  testing::TempDir dir;
  SynthOptions o = SmallOptions(dir / "a");
  o.trajectory = synth::TrajectoryKind::kShake;  // Blurred by default.
  o.seed = 5;
  RenderTwiceWithOtherThreads(o, dir.path());
}

TEST(RunSynth, SequenceRendersTheFramesItWrites) {
  testing::TempDir dir;
  const SynthOptions o = SmallOptions(dir / "seq");
  RunSynth(o);
  const SyntheticSequence sequence(o);
  ASSERT_EQ(sequence.size(), 5u);
  const SynthFrame frame = sequence.Render(3);
  const RgbdSequence written = RgbdSequence::Open(dir / "seq");
  EXPECT_EQ(cv::norm(frame.color, written.LoadColor(3), cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(frame.depth, written.LoadDepthRaw(3), cv::NORM_INF), 0.0);
  EXPECT_EQ(FormatTimestamp(frame.timestamp), "0.100000");
}

TEST(RunSynth, BrightnessChangeScalesTheImages) {
  SynthOptions o = SmallOptions("");
  o.frames = 30;
  const SyntheticSequence steady(o);
  o.brightness_change = 0.4;
  const SyntheticSequence changing(o);
  double lowest = 10, highest = 0;
  for (size_t i : {0, 5, 10, 15, 20, 25}) {
    const double ratio =
        cv::mean(changing.Render(i).color)[1] / cv::mean(steady.Render(i).color)[1];
    lowest = std::min(lowest, ratio);
    highest = std::max(highest, ratio);
  }
  EXPECT_GT(highest - lowest, 0.2);
  EXPECT_GT(lowest, 0.55);
  EXPECT_LT(highest, 1.45);
}

TEST(RunSynth, MotionBlurSoftensMovingFrames) {
  SynthOptions o = SmallOptions("");
  o.frames = 60;
  o.trajectory = synth::TrajectoryKind::kRotation;
  const SyntheticSequence sharp(o);
  o.motion_blur = 6;
  const SyntheticSequence blurred(o);
  auto gradient_energy = [](const cv::Mat& color) {
    cv::Mat gray, dx;
    cv::cvtColor(color, gray, cv::COLOR_BGR2GRAY);
    cv::Sobel(gray, dx, CV_32F, 1, 0);
    return cv::norm(dx, cv::NORM_L2SQR);
  };
  // The pan is fastest mid-sequence (about 2 px per frame here).
  EXPECT_LT(gradient_energy(blurred.Render(30).color),
            0.8 * gradient_energy(sharp.Render(30).color));
  // Depth and ground truth are those of the frame's timestamp either way.
  EXPECT_EQ(cv::norm(blurred.Render(30).depth, sharp.Render(30).depth, cv::NORM_INF), 0.0);
}

TEST(RunSynth, ShakeIsBlurredByDefaultAndSharpWithZeroBlur) {
  SynthOptions o = SmallOptions("");
  o.frames = 60;
  o.trajectory = synth::TrajectoryKind::kShake;
  const SyntheticSequence blurred(o);  // motion_blur unset: the shake's default.
  o.motion_blur = 0;
  const SyntheticSequence sharp(o);
  o.motion_blur = kShakeMotionBlur;
  const SyntheticSequence explicitly_blurred(o);
  auto gradient_energy = [](const cv::Mat& color) {
    cv::Mat gray, dx, dy;
    cv::cvtColor(color, gray, cv::COLOR_BGR2GRAY);
    cv::Sobel(gray, dx, CV_32F, 1, 0);
    cv::Sobel(gray, dy, CV_32F, 0, 1);
    return cv::norm(dx, cv::NORM_L2SQR) + cv::norm(dy, cv::NORM_L2SQR);
  };
  for (size_t i : {10, 30, 45}) {
    const SynthFrame frame = blurred.Render(i), sharp_frame = sharp.Render(i);
    // The image moves about 6 pixels per frame here (fx = 131): blurred by
    // min(8, 6) pixels along the motion.
    EXPECT_LT(gradient_energy(frame.color), 0.8 * gradient_energy(sharp_frame.color)) << i;
    EXPECT_EQ(cv::norm(frame.color, explicitly_blurred.Render(i).color, cv::NORM_INF), 0.0) << i;
    // Blur does not touch depth (noisy by default) or the ground truth.
    EXPECT_EQ(cv::norm(frame.depth, sharp_frame.depth, cv::NORM_INF), 0.0) << i;
    EXPECT_EQ(frame.T_world_cam.translation, sharp_frame.T_world_cam.translation);
  }
  // Zero blur renders the plain view of the frame's pose.
  const SynthFrame frame = sharp.Render(30);
  const synth::Renderer renderer(sharp.scene(), sharp.camera());
  EXPECT_EQ(cv::norm(frame.color, synth::ToColor8(renderer.Render(frame.T_world_cam).color),
                     cv::NORM_INF),
            0.0);
}

TEST(RunSynth, ReplacesAnExistingSequenceOnlyWhenDone) {
  testing::TempDir dir;
  SynthOptions o = SmallOptions(dir / "seq");
  o.frames = 2;
  RunSynth(o);
  const auto before = Contents(dir / "seq");
  o.frames = 0;  // Invalid: the old folder stays as it was.
  EXPECT_THROW(RunSynth(o), UsageError);
  EXPECT_TRUE(Contents(dir / "seq") == before);
  o.frames = 3;
  RunSynth(o);
  EXPECT_EQ(Contents(dir / "seq").size(), 2u * 3u + 7u);
  EXPECT_EQ(Contents(dir / "seq").at(".rrslam-output"), "rrslam-synth\n");
  EXPECT_EQ(testing::TemporaryLeftovers(dir), std::vector<std::string>{});
}

// Pixels where either view sees a face of a changed box (the moved box at its
// old or new place, an added box), dilated by 2 pixels for the anti-aliased
// outlines. CV_8UC1, 255 = changed.
cv::Mat ChangedPixels(const synth::Scene& standard, const synth::Scene& changed,
                      const PinholeCamera& camera, const Rigid3d& T_world_cam) {
  const synth::SceneChangeInfo info = synth::DescribeSceneChange(synth::SceneChange::kMovedBox);
  auto is_changed_face = [&](const synth::Surface& s) {
    if (s.id >= static_cast<int>(standard.surfaces().size())) return true;  // Added.
    for (const auto& m : info.moved) {
      if (s.name.size() == m.from.name.size() + 3 && s.name.rfind(m.from.name + ".", 0) == 0) {
        return true;
      }
    }
    return false;
  };
  const cv::Mat a = synth::Renderer(standard, camera).Render(T_world_cam).surface_id;
  const cv::Mat b = synth::Renderer(changed, camera).Render(T_world_cam).surface_id;
  cv::Mat mask(a.size(), CV_8UC1, cv::Scalar(0));
  for (int r = 0; r < a.rows; ++r) {
    for (int c = 0; c < a.cols; ++c) {
      const int sa = a.at<int>(r, c), sb = b.at<int>(r, c);
      if ((sa >= 0 && is_changed_face(standard.surface(sa))) ||
          (sb >= 0 && is_changed_face(changed.surface(sb)))) {
        mask.at<uint8_t>(r, c) = 255;
      }
    }
  }
  cv::dilate(mask, mask, cv::Mat::ones(5, 5, CV_8UC1));
  return mask;
}

TEST(RunSynth, MovedBoxChangesOnlyThePixelsOfTheChangedBoxes) {
  // A full-turn loop (20 s) looks at the changed places and away from them.
  SynthOptions o = SmallOptions({});
  o.frames = 600;
  SynthOptions c = o;
  c.scene_change = "moved-box";
  const SyntheticSequence standard(o), changed(c);
  ASSERT_EQ(changed.groundtruth().size(), standard.groundtruth().size());
  int frames_with_change = 0, frames_without = 0;
  for (size_t i = 0; i < standard.size(); i += 20) {
    const SynthFrame a = standard.Render(i), b = changed.Render(i);
    ASSERT_EQ(a.T_world_cam.translation, b.T_world_cam.translation);
    const cv::Mat mask =
        ChangedPixels(standard.scene(), changed.scene(), standard.camera(), a.T_world_cam);
    const int changed_pixels = cv::countNonZero(mask);
    if (changed_pixels == 0) {
      // Nothing changed in view: the same frame to the bit, depth noise and
      // holes included.
      ++frames_without;
      EXPECT_EQ(cv::norm(a.color, b.color, cv::NORM_INF), 0.0) << i;
      EXPECT_EQ(cv::norm(a.depth, b.depth, cv::NORM_INF), 0.0) << i;
      continue;
    }
    // Elsewhere the colour is identical; so is the depth (noise is drawn per
    // pixel), except where a hole appears in one frame only: the hole rate is
    // normalized over the whole frame, which the change alters a little.
    int holes_differ = 0, outside = 0, depth_differs_inside = 0;
    for (int r = 0; r < mask.rows; ++r) {
      for (int col = 0; col < mask.cols; ++col) {
        const uint16_t da = a.depth.at<uint16_t>(r, col), db = b.depth.at<uint16_t>(r, col);
        if (mask.at<uint8_t>(r, col)) {
          if (da != db) ++depth_differs_inside;
          continue;
        }
        ++outside;
        ASSERT_EQ(a.color.at<cv::Vec3b>(r, col), b.color.at<cv::Vec3b>(r, col))
            << "frame " << i << " pixel (" << col << ", " << r << ")";
        if (da != 0 && db != 0) {
          ASSERT_EQ(da, db) << "frame " << i << " pixel (" << col << ", " << r << ")";
        } else if ((da == 0) != (db == 0)) {
          ++holes_differ;
        }
      }
    }
    EXPECT_LT(holes_differ, 0.01 * outside) << i;
    if (changed_pixels >= 500) {
      // A clearly visible change: the depth differs there.
      ++frames_with_change;
      EXPECT_GT(depth_differs_inside, changed_pixels / 4) << i;
    }
  }
  EXPECT_GE(frames_with_change, 3);
  EXPECT_GE(frames_without, 3);
}

TEST(RunSynth, SynthJsonRecordsTheSceneChange) {
  testing::TempDir dir;
  SynthOptions o = SmallOptions(dir / "seq");
  o.frames = 2;
  RunSynth(o);
  auto info = nlohmann::json::parse(ReadFileToString(dir / "seq" / "synth.json"));
  EXPECT_EQ(info["options"]["scene_change"], "none");
  EXPECT_EQ(info["scene_change"]["name"], "none");
  EXPECT_TRUE(info["scene_change"]["moved"].empty());
  EXPECT_TRUE(info["scene_change"]["added"].empty());
  const size_t standard_surfaces = info["surfaces"].size();

  o.scene_change = "moved-box";
  RunSynth(o);
  info = nlohmann::json::parse(ReadFileToString(dir / "seq" / "synth.json"));
  EXPECT_EQ(info["options"]["scene_change"], "moved-box");
  const auto& change = info["scene_change"];
  EXPECT_EQ(change["name"], "moved-box");
  const synth::SceneChangeInfo expected = synth::DescribeSceneChange(synth::SceneChange::kMovedBox);
  auto vec = [](const nlohmann::json& j) {
    return Eigen::Vector3d(j.at(0).get<double>(), j.at(1).get<double>(), j.at(2).get<double>());
  };
  ASSERT_EQ(change["moved"].size(), 1u);
  const auto& moved = change["moved"][0];
  EXPECT_EQ(moved["box"], "screen");
  EXPECT_EQ(moved["index"].get<int>(), expected.moved[0].index);
  EXPECT_TRUE(vec(moved["from"]["centre"]).isApprox(expected.moved[0].from.centre_world));
  EXPECT_TRUE(vec(moved["to"]["centre"]).isApprox(expected.moved[0].to.centre_world));
  EXPECT_TRUE(vec(moved["to"]["size"]).isApprox(expected.moved[0].to.size));
  EXPECT_GE(moved["displacement_m"].get<double>(), 0.5);
  const auto regions = expected.ChangedRegions();
  EXPECT_TRUE(vec(moved["from"]["bounds_min"]).isApprox(regions[0].min()));
  EXPECT_TRUE(vec(moved["to"]["bounds_max"]).isApprox(regions[1].max()));
  ASSERT_EQ(change["added"].size(), 1u);
  const auto& added = change["added"][0];
  EXPECT_EQ(added["box"], "crate3");
  EXPECT_EQ(added["material"], "cardboard");
  EXPECT_TRUE(vec(added["centre"]).isApprox(expected.added[0].box.centre_world));
  EXPECT_TRUE(vec(added["size"]).isApprox(expected.added[0].box.size));
  EXPECT_TRUE(vec(added["bounds_min"]).isApprox(regions[2].min()));
  EXPECT_TRUE(vec(added["bounds_max"]).isApprox(regions[2].max()));
  // The added box's faces come after every standard surface.
  ASSERT_EQ(info["surfaces"].size(), standard_surfaces + 5);
  EXPECT_EQ(info["surfaces"][standard_surfaces], "crate3.+x");
}

// The executable: exit codes and what it leaves behind.
class SynthTool : public ::testing::Test {
 protected:
  testing::TempDir dir_;
  const std::string small_ = " --width 96 --height 72 --frames 3 --texel-size 0.01 -q";
};

TEST_F(SynthTool, WritesASequence) {
  const auto result = testing::RunTool(
      "synth", "--out " + (dir_ / "seq").string() + small_ + " --trajectory rotation --seed 3");
  ASSERT_EQ(result.exit_code, 0) << result.output;
  EXPECT_TRUE(fs::exists(dir_ / "seq" / "groundtruth.txt"));
  EXPECT_EQ(RgbdSequence::Open(dir_ / "seq").size(), 3u);
}

TEST_F(SynthTool, ShakeRecordsItsBlurAndNoiseAndHonoursAnExplicitZeroBlur) {
  for (const auto& [args, blur] : {std::pair<std::string, double>{"", kShakeMotionBlur},
                                   std::pair<std::string, double>{" --motion-blur 0", 0.0},
                                   std::pair<std::string, double>{" --motion-blur 2.5", 2.5}}) {
    const fs::path seq = dir_ / "seq";
    const auto result =
        testing::RunTool("synth", "--out " + seq.string() + small_ + " --trajectory shake" + args);
    ASSERT_EQ(result.exit_code, 0) << args << "\n" << result.output;
    const auto info = nlohmann::json::parse(ReadFileToString(seq / "synth.json"));
    EXPECT_EQ(info["options"]["trajectory"], "shake");
    EXPECT_DOUBLE_EQ(info["options"]["motion_blur"].get<double>(), blur) << args;
    EXPECT_DOUBLE_EQ(info["options"]["depth_noise"].get<double>(), 1.425e-3) << args;
    if (blur == 0) {
      // No blur at all: the frames of the library with motion_blur = 0.
      SynthOptions o;
      o.trajectory = synth::TrajectoryKind::kShake;
      o.width = 96;
      o.height = 72;
      o.frames = 3;
      o.texel_size = 0.01;
      o.motion_blur = 0;
      const SyntheticSequence sharp(o);
      const RgbdSequence written = RgbdSequence::Open(seq);
      for (size_t i = 0; i < 3; ++i) {
        EXPECT_EQ(cv::norm(sharp.Render(i).color, written.LoadColor(i), cv::NORM_INF), 0.0) << i;
      }
    }
  }
  // The other trajectories stay sharp by default.
  const auto result = testing::RunTool(
      "synth", "--out " + (dir_ / "seq").string() + small_ + " --trajectory sweep");
  ASSERT_EQ(result.exit_code, 0) << result.output;
  const auto info = nlohmann::json::parse(ReadFileToString(dir_ / "seq" / "synth.json"));
  EXPECT_DOUBLE_EQ(info["options"]["motion_blur"].get<double>(), 0.0);
}

TEST_F(SynthTool, BadOptionsExit64AndWriteNothing) {
  for (const std::string args :
       {" --frames 0", " --trajectory circle", " --depth-holes 2", " --width abc",
        " --no-such-flag", " --motion-blur -1", " --motion-blur abc", " --depth-scale-error 0.5",
        " --depth-scale-error -0.7"}) {
    const auto result =
        testing::RunTool("synth", "--out " + (dir_ / "seq").string() + small_ + args);
    EXPECT_EQ(result.exit_code, 64) << args << "\n" << result.output;
    EXPECT_FALSE(result.output.empty());
  }
  // --out is required.
  EXPECT_EQ(testing::RunTool("synth", small_).exit_code, 64);
  EXPECT_TRUE(fs::is_empty(dir_.path()));
}

TEST_F(SynthTool, ChangeNamesItsValuesAndRejectsOthers) {
  auto result = testing::RunTool(
      "synth", "--out " + (dir_ / "seq").string() + small_ + " --change moved-box");
  ASSERT_EQ(result.exit_code, 0) << result.output;
  const auto info = nlohmann::json::parse(ReadFileToString(dir_ / "seq" / "synth.json"));
  EXPECT_EQ(info["scene_change"]["name"], "moved-box");
  result = testing::RunTool("synth", "--out " + (dir_ / "bad").string() + small_ + " --change foo");
  EXPECT_EQ(result.exit_code, 64) << result.output;
  EXPECT_NE(result.output.find("scene_change = foo; must be none or moved-box"), std::string::npos)
      << result.output;
  EXPECT_FALSE(fs::exists(dir_ / "bad"));
}

// The building: walked by the tour only, without scene changes; the tour
// walks nothing else. Wrong pairs are usage errors naming both options.
TEST_F(SynthTool, BuildingGoesWithTheTourOnly) {
  auto result = testing::RunTool(
      "synth", "--out " + (dir_ / "seq").string() + small_ + " --scene building --trajectory tour");
  ASSERT_EQ(result.exit_code, 0) << result.output;
  const auto info = nlohmann::json::parse(ReadFileToString(dir_ / "seq" / "synth.json"));
  EXPECT_EQ(info["options"]["scene"], "building");
  EXPECT_EQ(info["options"]["trajectory"], "tour");
  EXPECT_EQ(info["scene_change"]["name"], "none");
  EXPECT_EQ(info["surfaces"][0], "building.+x");
  EXPECT_EQ(RgbdSequence::Open(dir_ / "seq").size(), 3u);

  const fs::path bad = dir_ / "bad";
  for (const auto& [args, message] :
       {std::pair<std::string, std::string>{
            " --scene building --trajectory tour --change moved-box",
            "--change moved-box edits the standard room, not "
            "--scene building"},
        {" --scene standard --trajectory tour", "--trajectory tour needs --scene building"},
        {" --trajectory tour", "--trajectory tour needs --scene building"},
        {" --scene building", "--scene building is walked by --trajectory tour only"},
        {" --scene building --trajectory sweep",
         "--scene building is walked by --trajectory tour only"},
        {" --scene house --trajectory tour", "--scene"}}) {
    result = testing::RunTool("synth", "--out " + bad.string() + small_ + args);
    EXPECT_EQ(result.exit_code, 64) << args << "\n" << result.output;
    EXPECT_NE(result.output.find(message), std::string::npos) << args << "\n" << result.output;
    EXPECT_FALSE(fs::exists(bad)) << args;
  }
}

TEST_F(SynthTool, UnwritableOutputExits73AndLeavesNothing) {
  // The parent folder does not exist.
  auto result = testing::RunTool("synth", "--out " + (dir_ / "missing" / "seq").string() + small_);
  EXPECT_EQ(result.exit_code, 73) << result.output;
  EXPECT_NE(result.output.find("missing"), std::string::npos) << result.output;
  // The parent is a file.
  testing::WriteTextFile(dir_ / "file", "x");
  result = testing::RunTool("synth", "--out " + (dir_ / "file" / "seq").string() + small_);
  EXPECT_EQ(result.exit_code, 73) << result.output;
  // The output path is an existing file: kept as it was.
  result = testing::RunTool("synth", "--out " + (dir_ / "file").string() + small_);
  EXPECT_EQ(result.exit_code, 73) << result.output;
  EXPECT_EQ(ReadFileToString(dir_ / "file"), "x");
  std::vector<std::string> left;
  for (const auto& entry : fs::directory_iterator(dir_.path()))
    left.push_back(entry.path().filename());
  EXPECT_EQ(left, std::vector<std::string>{"file"});
}

// Issue 36: --out is replaced only when it is empty or an earlier output of
// rrslam-synth; a folder holding anything else is refused and kept.
TEST_F(SynthTool, RefusesAFolderWithOtherFilesAndReplacesItsOwnOutput) {
  const fs::path seq = dir_ / "seq";
  fs::create_directories(seq);
  testing::WriteTextFile(seq / "notes.txt", "keep\n");
  auto result = testing::RunTool("synth", "--out " + seq.string() + small_);
  EXPECT_EQ(result.exit_code, 73) << result.output;
  EXPECT_NE(
      result.output.find(seq.string() + ": holds files rrslam-synth did not write (notes.txt)"),
      std::string::npos)
      << result.output;
  EXPECT_EQ(ReadFileToString(seq / "notes.txt"), "keep\n");
  EXPECT_FALSE(fs::exists(seq / "rgb.txt"));
  EXPECT_EQ(testing::TemporaryLeftovers(dir_), std::vector<std::string>{});

  fs::remove(seq / "notes.txt");
  ASSERT_EQ(testing::RunTool("synth", "--out " + seq.string() + small_).exit_code, 0);
  result = testing::RunTool("synth", "--out " + seq.string() + small_ + " --seed 2");
  ASSERT_EQ(result.exit_code, 0) << result.output;  // Its own output: replaced.
  EXPECT_EQ(nlohmann::json::parse(ReadFileToString(seq / "synth.json"))["options"]["seed"], 2);

  // A file of someone else's among its images makes the folder foreign too.
  testing::WriteTextFile(seq / "rgb" / "mine.png", "x");
  result = testing::RunTool("synth", "--out " + seq.string() + small_);
  EXPECT_EQ(result.exit_code, 73) << result.output;
  EXPECT_NE(result.output.find("(rgb/mine.png)"), std::string::npos) << result.output;
  EXPECT_EQ(ReadFileToString(seq / "rgb" / "mine.png"), "x");
}

// Issue 36: SIGTERM or SIGINT while writing removes the temporary folder;
// the process dies of the signal (143, 130 in a shell) and an earlier
// output under --out is kept as it was.
TEST_F(SynthTool, InterruptionRemovesTheTemporaryFolder) {
  const fs::path seq = dir_ / "seq";
  ASSERT_EQ(testing::RunTool("synth", "--out " + seq.string() + small_).exit_code, 0);
  const std::string before = ReadFileToString(seq / "groundtruth.txt");
  const std::string tool = testing::Quote(testing::BinDir() / "rrslam-synth");
  for (const auto& [signal, status] : {std::pair{"TERM", 143}, std::pair{"INT", 130}}) {
    // Job control on (set -m), so that the background job does not ignore SIGINT.
    const std::string script =
        "set -m; " + tool + " --out " + testing::Quote(seq) +
        " --width 96 --height 72 --frames 5000 --texel-size 0.01 -q --seed 9 & pid=$!; "
        "for i in $(seq 1200); do ls " +
        testing::Quote(dir_.path()) +
        " | grep -q 'tmp$' && break; sleep 0.05; done; sleep 0.3; kill -" + signal +
        " $pid; wait $pid; echo status $?";
    const auto r = testing::RunCommand("bash -c " + ShellQuote(script));
    EXPECT_NE(r.output.find("status " + std::to_string(status)), std::string::npos)
        << signal << ": " << r.output;
    EXPECT_EQ(testing::TemporaryLeftovers(dir_), std::vector<std::string>{}) << signal;
    EXPECT_EQ(ReadFileToString(seq / "groundtruth.txt"), before) << signal;
  }
}

TEST_F(SynthTool, HelpListsEveryFlagWithItsDefault) {
  const auto result = testing::RunTool("synth", "--help");
  ASSERT_EQ(result.exit_code, 0);
  for (const char* flag :
       {"--out", "--trajectory", "--frames", "--fps", "--width", "--height", "--fx", "--fy", "--cx",
        "--cy", "--depth-noise", "--depth-holes", "--depth-scale-error", "--brightness-change",
        "--motion-blur", "--seed", "--texel-size", "--threads", "Exit codes"}) {
    EXPECT_NE(result.output.find(flag), std::string::npos) << flag;
  }
  EXPECT_NE(result.output.find("300"), std::string::npos);
  EXPECT_NE(result.output.find("0.001425"), std::string::npos);
  EXPECT_NE(result.output.find("loop"), std::string::npos);
  EXPECT_NE(result.output.find("shake"), std::string::npos);
  EXPECT_NE(result.output.find("--change TEXT=none"), std::string::npos);
  EXPECT_NE(result.output.find("--scene TEXT:{standard,building}=standard"), std::string::npos)
      << result.output;
  EXPECT_NE(result.output.find("tour"), std::string::npos);
  EXPECT_NE(result.output.find("moved-box"), std::string::npos);
}

}  // namespace
}  // namespace rrslam
