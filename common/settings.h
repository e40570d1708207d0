// Camera and ORB-extractor settings in ORB-SLAM2's RGB-D YAML layout.
//
// Files look like ../shared/data/settings/tum1.yaml (`%YAML:1.0`, flat keys):
//   Camera.fx Camera.fy Camera.cx Camera.cy        required, pixels
//   Camera.k1 Camera.k2 Camera.p1 Camera.p2 Camera.k3   distortion, default 0
//   Camera.width Camera.height                     pixels, default 0 = from images
//   Camera.fps                                     default 30
//   Camera.bf                                      baseline (m) times fx, default 40
//   Camera.RGB                                     1 RGB, 0 BGR order, default 1
//   ThDepth                                        close/far threshold in baselines, default 40
//   DepthMapFactor                                 depth PNG units per metre, default 5000
//   DepthNoise.model / .k2 / .sampling             how depth is weighted (rrslam's keys; see
//                                                  DepthNoise), default ORB-SLAM2's
//   DepthDisparitySigma                            older form of DepthNoise (see there)
//   ORBextractor.nFeatures/scaleFactor/nLevels/iniThFAST/minThFAST
// Keys other than these are ignored, as ORB-SLAM2 does.
#pragma once

#include <filesystem>
#include <span>
#include <string>

#include "common/camera.h"

namespace rrslam {

struct OrbSettings {
  int n_features = 1000;      // Features per image, over all levels; in [1, 100000].
  double scale_factor = 1.2;  // Scale between pyramid levels; in (1, 4].
  int n_levels = 8;           // Pyramid levels; in [1, 16].
  int ini_th_fast = 20;       // FAST threshold tried first; in [1, 255].
  int min_th_fast = 7;        // FAST threshold for cells that give none; in [1, ini_th_fast].
};

// How tracking weighs a depth reading z (metres) of a keypoint: the noise of
// the virtual disparity d = bf / z that it gives (docs/track.md, "Depth
// weighting"). Used wherever depth enters a cost: pose optimization, local and
// global bundle adjustment, the depth checks of triangulation and fusion.
//   - kOrbSlam2 (`DepthNoise.model: orbslam2`, or no key): as ORB-SLAM2, the
//     virtual right coordinate u_R = u - d has the keypoint's own pixel sigma
//     (1 px at pyramid level 0, scale^level above).
//   - kQuadratic (`DepthNoise.model: quadratic`): the sensor's depth error is
//     sigma_z = k2 z^2 metres (`DepthNoise.k2`, 1/m; structured light and
//     time of flight: about 1.425e-3 for the Kinect, Khoshelham and Elberink
//     2012), which is bf * k2 pixels of disparity at every depth, combined
//     with the error of reading the depth at the keypoint's pixel
//     (`DepthNoise.sampling`, pixels of disparity: slanted surfaces, depth
//     edges) as hypot(bf * k2, sampling); the disparity is weighted by it,
//     independently of the keypoint's pyramid level.
// The older key `DepthDisparitySigma: s` is the quadratic model with k2 = 0
// and sampling = s (the same weights: s = hypot(bf * k2, sampling)); a file
// may give it or the DepthNoise keys, not both.
struct DepthNoise {
  enum class Model { kOrbSlam2, kQuadratic };
  Model model = Model::kOrbSlam2;
  double k2 = 0.0;        // 1/m; >= 0; quadratic only.
  double sampling = 0.0;  // Pixels of disparity; >= 0; quadratic only.

  // The disparity sigma in pixels for a camera of baseline times fx `bf`;
  // 0 for kOrbSlam2.
  double DisparitySigma(double bf) const;
};

struct Settings {
  // Intrinsics (pixels) and distortion.
  double fx = 0, fy = 0, cx = 0, cy = 0;
  Distortion distortion;
  int width = 0;  // Image size in pixels; 0 = not given (taken from the images).
  int height = 0;
  double fps = 30.0;
  double bf = 40.0;                  // Baseline (metres) times fx (pixels), for virtual stereo.
  bool rgb_order = true;             // Colour images are RGB (true) or BGR (false). rrslam reads
                                     // images through OpenCV, so this matters only for raw buffers.
  double th_depth = 40.0;            // Close/far threshold in baselines (ORB-SLAM2's ThDepth).
  double depth_map_factor = 5000.0;  // Depth PNG units per metre.
  DepthNoise depth_noise;            // How depth is weighted; default ORB-SLAM2's.
  OrbSettings orb;

  std::filesystem::path source;  // File these settings came from (empty if built in code).

  // Baseline in metres: bf / fx.
  double Baseline() const { return bf / fx; }
  // Close/far depth threshold in metres, as ORB-SLAM2: bf * ThDepth / fx.
  double ThDepthMetres() const { return bf * th_depth / fx; }
  PinholeCamera Camera() const { return PinholeCamera(fx, fy, cx, cy, width, height, distortion); }

  // Validates every field; on failure returns false and names the violated
  // constraint in `why` ("ORBextractor.nLevels = 0; must be in [1, 16]").
  bool Check(std::string* why) const;
};

// Reads and checks a settings file. Throws NoInputError when it is missing,
// DataError when it is not parseable YAML, not one YAML document holding a
// map of keys at column 0 (ORB-SLAM2's layout; other shapes can hang
// OpenCV's parser, see settings.cc), lacks Camera.fx/fy/cx/cy, or fails
// Check(); the message names the file and the key (or the line).
Settings ReadSettings(const std::filesystem::path& path);

// Parses and checks settings text (e.g. the copy a features file records) with
// the errors of ReadSettings; `name` stands for the file in messages. The
// result's `source` is empty.
Settings ParseSettings(const std::string& text, const std::string& name);

// One setting as two sources give it (e.g. the settings a file was made with,
// and this run's), for consistency checks.
struct SettingPair {
  const char* key;  // "Camera.fx"
  double recorded;  // In the file.
  double given;     // In this run's settings.
};
// The first pair whose values differ by more than text rounding (relative
// 1e-9), or nullptr when all agree.
const SettingPair* FirstDifferentSetting(std::span<const SettingPair> pairs);

// The viewpoint of ORB-SLAM2's map viewer (its settings' Viewer.ViewpointX,
// Y, Z and F): the eye at (x, y, z) metres in the map frame, looking at the
// map's origin with "up" along -y (the first camera's up), with a focal
// length of f pixels for a 1024 x 768 view (Pangolin's ProjectionMatrix and
// ModelViewLookAt as ORB-SLAM2's Viewer.cc sets them). Defaults are
// ORB-SLAM2's example values.
struct Viewpoint {
  double x = 0, y = -0.7, z = -1.8;  // Eye, metres, map frame.
  double f = 500;                    // Focal length, pixels at 1024 x 768.
};

// Reads Viewer.ViewpointX, Y, Z and F from a settings file in the same
// layout (other keys ignored, all four required; f > 0, the eye not at the
// origin). Throws NoInputError when the file is missing, DataError naming
// the file and the key otherwise.
Viewpoint ReadViewpoint(const std::filesystem::path& path);

// Parses the viewpoint from settings text with the errors of ReadViewpoint;
// `name` stands for the file in messages.
Viewpoint ParseViewpoint(const std::string& text, const std::string& name);

// Formats settings in the same layout (deterministic text).
std::string FormatSettings(const Settings& settings);

// Writes settings atomically. Throws CantCreateError.
void WriteSettings(const std::filesystem::path& path, const Settings& settings);

}  // namespace rrslam
