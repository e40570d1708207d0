// rrslam-synth: renders a TUM-layout RGB-D sequence of a textured room (or of
// a building of six rooms, building.h) with exact ground truth (see
// docs/synth.md).
//
// Output folder (written atomically: OUT.XXXXXX.tmp, then renamed to OUT; an
// existing OUT is replaced only when it is empty or an earlier rrslam-synth
// output, see common/atomic_file.h):
//   rgb/<timestamp>.png     8-bit colour (BGR in memory, RGB PNG)
//   depth/<timestamp>.png   16-bit depth, 5000 units per metre, 0 = no depth
//   rgb.txt, depth.txt      `timestamp path` lists with 3 '#' header lines
//   associations.txt        `rgb_ts rgb_path depth_ts depth_path` (no header)
//   groundtruth.txt         TUM trajectory of T_world_cam at the frame timestamps
//   settings.yaml           ORB-SLAM2 RGB-D settings matching the rendering
//   synth.json              producer, options and scene summary
//   .rrslam-output          marker: "rrslam-synth", this tool's folder
// Timestamps are i / fps seconds (i = 0, 1, ...), printed with 6 decimals.
//
// Building blocks for tests and other stages live in namespace rrslam::synth:
// Scene (scene.h), CameraPath (camera_path.h), Renderer (renderer.h), sensor
// effects (sensor.h). SyntheticSequence below renders the exact frames that
// RunSynth writes, in memory.
#pragma once

#include <cstdint>
#include <filesystem>
#include <memory>
#include <opencv2/core/mat.hpp>
#include <optional>
#include <string>

#include "common/camera.h"
#include "common/settings.h"
#include "common/trajectory.h"
#include "stages/synth/camera_path.h"
#include "stages/synth/scene.h"

namespace rrslam {

namespace synth {
class Scene;
class Renderer;
}  // namespace synth

// Options of rrslam-synth. Every field has a default; Check() validates all of
// them (except `out`, which only RunSynth needs).
struct SynthOptions {
  // Output sequence folder; its parent must exist. An existing folder is
  // replaced as a whole only when it is empty or an earlier rrslam-synth output.
  std::filesystem::path out;
  // Scene: the standard room or the building (synth::SceneKind, scene.h;
  // building.h).
  synth::SceneKind scene = synth::SceneKind::kStandard;
  // Camera path (camera_path.h): loop, sweep, rotation, shake or turn in the
  // standard room; tour in the building (the only path there, and only
  // there). Sets the default of motion_blur.
  synth::TrajectoryKind trajectory = synth::TrajectoryKind::kLoop;
  // Number of frames; in [1, 100000].
  int frames = 300;
  // Frame rate, Hz; in (0, 1000]. Frame i is at t = i / fps seconds.
  double fps = 30.0;
  // Image size, pixels; each in [16, 8192].
  int width = 640;
  int height = 480;
  // Pinhole intrinsics, pixels. 0 = default: fx = 525 * width / 640,
  // fy = 525 * height / 480, cx = (320 * width / 640) - 0.5,
  // cy = (240 * height / 480) - 0.5 (a Kinect at 640 x 480: 525, 525, 319.5,
  // 239.5, scaled with the image). Given values: fx, fy in [1, 100000]; cx in
  // (0, width - 1], cy in (0, height - 1].
  double fx = 0, fy = 0, cx = 0, cy = 0;
  // Depth noise coefficient k, 1/m: Gaussian noise of sigma = k * z^2 metres
  // (Kinect v1). In [0, 0.05]; 0 = exact depth. On by default for every
  // trajectory.
  double depth_noise = 1.425e-3;
  // Expected fraction of pixels without depth, at depth edges, far range and
  // grazing angles first (sensor.h). In [0, 0.9]; 0 = every pixel has depth.
  double depth_holes = 0.02;
  // Depth scale error E, dimensionless: the simulated sensor is miscalibrated
  // and reports (1 + E) times the true depth, before noise and holes
  // (DepthSensorModel::scale_error); E = 0.01 is a 1% bias (2.02 m at 2 m).
  // In (-0.5, 0.5); 0 = calibrated. The ground truth and settings.yaml stay
  // exact: the bias is the sensor's, unknown to whoever reads the sequence.
  double depth_scale_error = 0.0;
  // Wander of the depth scale error, dimensionless: the sensor's bias drifts
  // over time (a warming Kinect), so frame i at t seconds reports
  // (1 + DepthScaleError(t)) times the true depth, with
  // DepthScaleError(t) = depth_scale_error + W sin(2 pi t / P). Unlike a
  // constant bias, which scales the whole world and is unobservable, a
  // changing bias bends the trajectory: a drift source that loop closing can
  // correct. W in [0, 0.2], |depth_scale_error| + W < 0.5; 0 = constant.
  double depth_scale_wander = 0.0;
  // Its period P, seconds; in [0.1, 3600].
  double depth_scale_period = 15.0;
  // Amplitude of the global exposure change over the sequence: the gain
  // varies smoothly within 1 +- brightness_change. In [0, 0.9].
  double brightness_change = 0.0;
  // Motion blur, pixels: each frame averages views over an exposure chosen so
  // that the image moves this far during it (at most one frame interval).
  // In [0, 64]; 0 = no blur. Unset = the trajectory's default
  // (DefaultMotionBlur(trajectory): no blur, except for shake); a value set
  // here, 0 included, is used whatever the trajectory. Read it through
  // MotionBlur().
  std::optional<double> motion_blur;
  // Seed of textures, noise, holes and exposure; the geometry and the camera
  // path do not depend on it.
  uint64_t seed = 0;
  // Texture resolution, metres per texel; in [0.0005, 0.05].
  double texel_size = 0.003;
  // Scene edit (synth::SceneChange, scene.h): "none" renders the standard
  // room; "moved-box" moves the screen and adds a crate, leaving everything
  // else bit-identical (same textures, camera path and noise), so that a map of
  // the standard room can be checked against the changed one. synth.json
  // records where the room changed. The building has no changes: "none" only.
  std::string scene_change = "none";
  // Worker threads; 0 = all hardware threads; in [0, 256]. The output does not
  // depend on it.
  int threads = 0;

  bool Check(std::string* why) const;
  // The part of Check() that pairs scene, trajectory and scene_change: the
  // building is walked by the tour only and has no scene changes; the tour
  // walks only the building.
  bool CheckSceneAndTrajectory(std::string* why) const;

  // motion_blur, or the trajectory's default when it is unset; pixels.
  double MotionBlur() const;
  // The depth scale error at t seconds (see depth_scale_wander).
  double DepthScaleError(double t) const;
  // Intrinsics with the defaults resolved (no distortion).
  PinholeCamera Camera() const;
  // ORB-SLAM2 settings for the sequence: the camera, fps, bf = 40 * fx / 525
  // (a 7.6 cm virtual baseline, bf = 40 at the default fx), ThDepth 40,
  // DepthMapFactor 5000, default ORB parameters.
  Settings MakeSettings() const;
  // The options as JSON (resolved intrinsics and motion blur; no `out` or
  // `threads`, which do not change the output).
  std::string ToJson() const;
};

// Motion blur (pixels of image motion during the exposure) of a trajectory
// kind when SynthOptions::motion_blur is unset: 0 for loop, sweep and
// rotation; kShakeMotionBlur for shake.
double DefaultMotionBlur(synth::TrajectoryKind kind);

// Default motion blur of the shake trajectory, pixels. The image moves about
// 26 pixels per frame there (2.8 deg at fx = 525), so 8 pixels is the blur of
// an exposure of about 10 ms (a third of the frame interval) at that speed,
// what an auto-exposed Kinect camera gets in a well-lit room. Clearly
// blurred, yet ORB still finds its features: at 640 x 480 FAST (threshold 20)
// keeps a fifth of its full-resolution corners, the coarser pyramid levels
// fill 1000 features, and 90% as many matches between consecutive frames
// agree with the ground truth as without blur (docs/synth.md).
inline constexpr double kShakeMotionBlur = 8.0;

// One frame as written by RunSynth.
struct SynthFrame {
  double timestamp = 0;  // Seconds.
  Rigid3d T_world_cam;   // Exact camera pose at the timestamp (ground truth).
  cv::Mat color;         // CV_8UC3, BGR.
  cv::Mat depth;         // CV_16UC1, SynthOptions' DepthMapFactor (5000) units per metre.
};

// The sequence RunSynth writes, rendered in memory on demand. Thread-safe
// after construction: frames may be rendered concurrently.
class SyntheticSequence {
 public:
  // Throws UsageError when options.Check() fails. Builds the scene (textures
  // on options.threads threads).
  explicit SyntheticSequence(const SynthOptions& options);
  ~SyntheticSequence();
  SyntheticSequence(const SyntheticSequence&) = delete;
  SyntheticSequence& operator=(const SyntheticSequence&) = delete;

  const SynthOptions& options() const { return options_; }
  size_t size() const { return groundtruth_.size(); }
  const Trajectory& groundtruth() const { return groundtruth_; }
  const PinholeCamera& camera() const { return camera_; }
  const synth::Scene& scene() const { return *scene_; }
  const synth::CameraPath& path() const { return path_; }
  double duration() const { return path_.duration(); }

  // Renders frame i (< size()).
  SynthFrame Render(size_t i) const;

 private:
  SynthOptions options_;
  PinholeCamera camera_;
  synth::CameraPath path_;
  Trajectory groundtruth_;
  std::unique_ptr<synth::Scene> scene_;
  std::unique_ptr<synth::Renderer> renderer_;
};

// Timestamp as printed in lists and file names: 6 decimals.
std::string FormatTimestamp(double seconds);

// Renders the sequence and writes the output folder (see the top of this
// file). Throws UsageError for invalid options (exit 64) and CantCreateError
// when the output cannot be written or options.out holds files rrslam-synth
// did not write (exit 73, before rendering); on error nothing is left under
// options.out (an existing folder there is kept unchanged).
void RunSynth(const SynthOptions& options);

}  // namespace rrslam
