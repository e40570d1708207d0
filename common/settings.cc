#include "common/settings.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <opencv2/core.hpp>
#include <sstream>
#include <string_view>

#include "common/atomic_file.h"
#include "common/errors.h"
#include "common/path_check.h"
#include "common/text.h"
#include "common/yaml_text.h"

namespace rrslam {
namespace {

// Reads a numeric key; returns false when absent. Throws when present but not numeric.
bool ReadNumber(const cv::FileStorage& fs, const std::string& key, const std::string& path,
                double* value) {
  const cv::FileNode node = fs[key];
  if (node.empty() || node.isNone()) return false;
  if (!node.isReal() && !node.isInt()) {
    throw DataError(path + ": " + key + " is not a number");
  }
  *value = static_cast<double>(node);
  return true;
}

bool ReadInt(const cv::FileStorage& fs, const std::string& key, const std::string& path,
             int* value) {
  double number = 0;
  if (!ReadNumber(fs, key, path, &number)) return false;
  if (number != std::floor(number) || std::fabs(number) > 1e9) {
    throw DataError(path + ": " + key + " = " + std::to_string(number) + " is not an integer");
  }
  *value = static_cast<int>(number);
  return true;
}

// The DepthNoise keys, or the older DepthDisparitySigma (see DepthNoise).
void ReadDepthNoise(const cv::FileStorage& fs, const std::string& path, DepthNoise* noise) {
  const cv::FileNode model = fs["DepthNoise.model"];
  double legacy = 0;
  const bool has_legacy = ReadNumber(fs, "DepthDisparitySigma", path, &legacy);
  const bool has_k2 = ReadNumber(fs, "DepthNoise.k2", path, &noise->k2);
  const bool has_sampling = ReadNumber(fs, "DepthNoise.sampling", path, &noise->sampling);
  const bool has_model = !model.empty() && !model.isNone();
  if (has_legacy && (has_model || has_k2 || has_sampling)) {
    throw DataError(path + ": gives both DepthDisparitySigma and DepthNoise.*; give one");
  }
  if (has_legacy) {
    *noise = {DepthNoise::Model::kQuadratic, 0.0, legacy};
    // A sigma of 0 was the older files' way to say ORB-SLAM2's weighting.
    if (legacy == 0) *noise = DepthNoise{};
    return;
  }
  if (!has_model) {
    if (has_k2 || has_sampling) {
      throw DataError(path +
                      ": DepthNoise.k2 / DepthNoise.sampling need DepthNoise.model: "
                      "quadratic");
    }
    return;
  }
  const std::string name = model.isString() ? static_cast<std::string>(model) : "";
  if (name == "orbslam2") {
    if (has_k2 || has_sampling) {
      throw DataError(path + ": DepthNoise.model = orbslam2 takes no DepthNoise.k2 / .sampling");
    }
    noise->model = DepthNoise::Model::kOrbSlam2;
  } else if (name == "quadratic") {
    noise->model = DepthNoise::Model::kQuadratic;
  } else {
    throw DataError(path + ": DepthNoise.model = " + (name.empty() ? "(not a name)" : name) +
                    "; must be orbslam2 or quadratic");
  }
}

// A settings file's text; NoInputError when it is not a regular file.
std::string ReadSettingsText(const std::filesystem::path& path) {
  RequireFile(path, "settings file");
  return ReadFileToString(path);
}

// Settings text as OpenCV YAML; DataError naming `name` when it is not.
cv::FileStorage OpenSettingsYaml(const std::string& text, const std::string& name) {
  if (text.empty()) throw DataError(name + ": empty settings file");
  return ParseYamlText(text, name,
                       "settings are one YAML document holding a map of keys at column 0");
}

}  // namespace

bool Settings::Check(std::string* why) const {
  auto fail = [&](const std::string& text) {
    if (why != nullptr) *why = text;
    return false;
  };
  auto positive = [](double v) { return std::isfinite(v) && v > 0; };
  if (!positive(fx)) return fail("Camera.fx = " + Format("%g", fx) + "; must be > 0");
  if (!positive(fy)) return fail("Camera.fy = " + Format("%g", fy) + "; must be > 0");
  if (!std::isfinite(cx)) return fail("Camera.cx is not finite");
  if (!std::isfinite(cy)) return fail("Camera.cy is not finite");
  for (double k : {distortion.k1, distortion.k2, distortion.p1, distortion.p2, distortion.k3}) {
    if (!std::isfinite(k)) return fail("Camera distortion coefficient is not finite");
  }
  if (width < 0 || width > 100000)
    return fail("Camera.width = " + std::to_string(width) + "; must be in [0, 100000]");
  if (height < 0 || height > 100000)
    return fail("Camera.height = " + std::to_string(height) + "; must be in [0, 100000]");
  if (!positive(fps)) return fail("Camera.fps = " + Format("%g", fps) + "; must be > 0");
  if (!positive(bf)) return fail("Camera.bf = " + Format("%g", bf) + "; must be > 0");
  if (!positive(th_depth)) return fail("ThDepth = " + Format("%g", th_depth) + "; must be > 0");
  if (depth_noise.model == DepthNoise::Model::kQuadratic) {
    for (const auto& [key, value] : {std::pair{"DepthNoise.k2", depth_noise.k2},
                                     {"DepthNoise.sampling", depth_noise.sampling}}) {
      if (!std::isfinite(value) || value < 0) {
        return fail(std::string(key) + " = " + Format("%g", value) + "; must be >= 0");
      }
    }
    if (!(depth_noise.DisparitySigma(bf) > 0)) {
      return fail(
          "DepthNoise.model = quadratic with DepthNoise.k2 = 0 and DepthNoise.sampling = 0 "
          "trusts depth without limit; give one of them > 0");
    }
  }
  if (!positive(depth_map_factor)) {
    return fail("DepthMapFactor = " + Format("%g", depth_map_factor) + "; must be > 0");
  }
  if (orb.n_features < 1 || orb.n_features > 100000) {
    return fail("ORBextractor.nFeatures = " + std::to_string(orb.n_features) +
                "; must be in [1, 100000]");
  }
  if (!(orb.scale_factor > 1.0 && orb.scale_factor <= 4.0)) {
    return fail("ORBextractor.scaleFactor = " + Format("%g", orb.scale_factor) +
                "; must be in (1, 4]");
  }
  if (orb.n_levels < 1 || orb.n_levels > 16) {
    return fail("ORBextractor.nLevels = " + std::to_string(orb.n_levels) + "; must be in [1, 16]");
  }
  if (orb.ini_th_fast < 1 || orb.ini_th_fast > 255) {
    return fail("ORBextractor.iniThFAST = " + std::to_string(orb.ini_th_fast) +
                "; must be in [1, 255]");
  }
  if (orb.min_th_fast < 1 || orb.min_th_fast > orb.ini_th_fast) {
    return fail("ORBextractor.minThFAST = " + std::to_string(orb.min_th_fast) +
                "; must be in [1, iniThFAST = " + std::to_string(orb.ini_th_fast) + "]");
  }
  return true;
}

double DepthNoise::DisparitySigma(double bf) const {
  return model == Model::kQuadratic ? std::hypot(bf * k2, sampling) : 0.0;
}

Settings ReadSettings(const std::filesystem::path& path) {
  Settings s = ParseSettings(ReadSettingsText(path), path.string());
  s.source = path;
  return s;
}

Settings ParseSettings(const std::string& text, const std::string& name) {
  const cv::FileStorage fs = OpenSettingsYaml(text, name);
  Settings s;
  try {
    for (const auto& [key, field] : {std::pair{"Camera.fx", &s.fx},
                                     {"Camera.fy", &s.fy},
                                     {"Camera.cx", &s.cx},
                                     {"Camera.cy", &s.cy}}) {
      if (!ReadNumber(fs, key, name, field)) throw DataError(name + ": missing " + key);
    }
    ReadNumber(fs, "Camera.k1", name, &s.distortion.k1);
    ReadNumber(fs, "Camera.k2", name, &s.distortion.k2);
    ReadNumber(fs, "Camera.p1", name, &s.distortion.p1);
    ReadNumber(fs, "Camera.p2", name, &s.distortion.p2);
    ReadNumber(fs, "Camera.k3", name, &s.distortion.k3);
    ReadInt(fs, "Camera.width", name, &s.width);
    ReadInt(fs, "Camera.height", name, &s.height);
    ReadNumber(fs, "Camera.fps", name, &s.fps);
    ReadNumber(fs, "Camera.bf", name, &s.bf);
    int rgb = 1;
    if (ReadInt(fs, "Camera.RGB", name, &rgb)) s.rgb_order = rgb != 0;
    ReadNumber(fs, "ThDepth", name, &s.th_depth);
    ReadNumber(fs, "DepthMapFactor", name, &s.depth_map_factor);
    // ORB-SLAM2 treats a zero factor as 1 (depth already in metres).
    if (s.depth_map_factor == 0) s.depth_map_factor = 1.0;
    ReadDepthNoise(fs, name, &s.depth_noise);
    ReadInt(fs, "ORBextractor.nFeatures", name, &s.orb.n_features);
    ReadNumber(fs, "ORBextractor.scaleFactor", name, &s.orb.scale_factor);
    ReadInt(fs, "ORBextractor.nLevels", name, &s.orb.n_levels);
    ReadInt(fs, "ORBextractor.iniThFAST", name, &s.orb.ini_th_fast);
    ReadInt(fs, "ORBextractor.minThFAST", name, &s.orb.min_th_fast);
  } catch (const cv::Exception&) {
    throw DataError(name + ": malformed settings value");
  }
  std::string why;
  if (!s.Check(&why)) throw DataError(name + ": " + why);
  return s;
}

Viewpoint ReadViewpoint(const std::filesystem::path& path) {
  return ParseViewpoint(ReadSettingsText(path), path.string());
}

Viewpoint ParseViewpoint(const std::string& text, const std::string& name) {
  const cv::FileStorage fs = OpenSettingsYaml(text, name);
  Viewpoint v;
  try {
    for (const auto& [key, field] : {std::pair{"Viewer.ViewpointX", &v.x},
                                     {"Viewer.ViewpointY", &v.y},
                                     {"Viewer.ViewpointZ", &v.z},
                                     {"Viewer.ViewpointF", &v.f}}) {
      if (!ReadNumber(fs, key, name, field)) throw DataError(name + ": missing " + key);
      if (!std::isfinite(*field)) throw DataError(name + ": " + key + " is not finite");
    }
  } catch (const cv::Exception&) {
    throw DataError(name + ": malformed settings value");
  }
  if (!(v.f > 0))
    throw DataError(name + ": Viewer.ViewpointF = " + Format("%g", v.f) + "; must be > 0");
  if (v.x == 0 && v.y == 0 && v.z == 0) {
    throw DataError(name + ": Viewer.ViewpointX/Y/Z is the origin, which the view looks at");
  }
  return v;
}

std::string FormatSettings(const Settings& s) {
  std::ostringstream out;
  // -0 is written as 0: OpenCV reads "-0" as the integer 0, so the text
  // would not read back to itself (found by common/fuzz/settings_fuzzer.cc).
  auto num = [](double v) { return Format("%.9g", v == 0 ? 0.0 : v); };
  out << "%YAML:1.0\n"
      << "# Camera and ORB parameters in the settings layout of ORB-SLAM2's RGB-D examples.\n"
      << "Camera.fx: " << num(s.fx) << "\n"
      << "Camera.fy: " << num(s.fy) << "\n"
      << "Camera.cx: " << num(s.cx) << "\n"
      << "Camera.cy: " << num(s.cy) << "\n"
      << "Camera.k1: " << num(s.distortion.k1) << "\n"
      << "Camera.k2: " << num(s.distortion.k2) << "\n"
      << "Camera.p1: " << num(s.distortion.p1) << "\n"
      << "Camera.p2: " << num(s.distortion.p2) << "\n"
      << "Camera.k3: " << num(s.distortion.k3) << "\n"
      << "Camera.width: " << s.width << "\n"
      << "Camera.height: " << s.height << "\n"
      << "Camera.fps: " << num(s.fps) << "\n"
      << "Camera.bf: " << num(s.bf) << "\n"
      << "Camera.RGB: " << (s.rgb_order ? 1 : 0) << "\n"
      << "ThDepth: " << num(s.th_depth) << "\n"
      << "DepthMapFactor: " << num(s.depth_map_factor) << "\n";
  if (s.depth_noise.model == DepthNoise::Model::kQuadratic) {
    out << "# Depth weighting: disparity sigma hypot(bf * k2, sampling) px (docs/track.md)\n"
        << "DepthNoise.model: quadratic\n"
        << "DepthNoise.k2: " << num(s.depth_noise.k2) << "\n"
        << "DepthNoise.sampling: " << num(s.depth_noise.sampling) << "\n";
  }
  out << "ORBextractor.nFeatures: " << s.orb.n_features << "\n"
      << "ORBextractor.scaleFactor: " << num(s.orb.scale_factor) << "\n"
      << "ORBextractor.nLevels: " << s.orb.n_levels << "\n"
      << "ORBextractor.iniThFAST: " << s.orb.ini_th_fast << "\n"
      << "ORBextractor.minThFAST: " << s.orb.min_th_fast << "\n";
  return out.str();
}

void WriteSettings(const std::filesystem::path& path, const Settings& settings) {
  WriteFileAtomically(path, FormatSettings(settings));
}

const SettingPair* FirstDifferentSetting(std::span<const SettingPair> pairs) {
  for (const SettingPair& p : pairs) {
    if (std::abs(p.recorded - p.given) > 1e-9 * std::max(1.0, std::abs(p.given))) return &p;
  }
  return nullptr;
}

}  // namespace rrslam
