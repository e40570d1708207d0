#include "common/settings.h"

#include <gtest/gtest.h>

#include "common/errors.h"
#include "common/testing.h"
#include "common/yaml_text.h"

namespace rrslam {
namespace {

TEST(Settings, ReadsTum1) {
  RRSLAM_REQUIRE_SHARED_DATA(data);
  const Settings s = ReadSettings(data / "settings" / "tum1.yaml");
  EXPECT_DOUBLE_EQ(s.fx, 517.306408);
  EXPECT_DOUBLE_EQ(s.cy, 255.313989);
  EXPECT_DOUBLE_EQ(s.distortion.k1, 0.262383);
  EXPECT_DOUBLE_EQ(s.distortion.k3, 1.163314);
  EXPECT_EQ(s.width, 640);
  EXPECT_EQ(s.height, 480);
  EXPECT_DOUBLE_EQ(s.bf, 40.0);
  EXPECT_DOUBLE_EQ(s.depth_map_factor, 5000.0);
  EXPECT_EQ(s.orb.n_features, 1000);
  EXPECT_DOUBLE_EQ(s.orb.scale_factor, 1.2);
  EXPECT_EQ(s.orb.n_levels, 8);
  EXPECT_EQ(s.orb.ini_th_fast, 20);
  EXPECT_EQ(s.orb.min_th_fast, 7);
  EXPECT_NEAR(s.ThDepthMetres(), 40.0 * 40.0 / 517.306408, 1e-12);
}

TEST(Settings, ReadsEveryShippedFile) {
  RRSLAM_REQUIRE_SHARED_DATA(data);
  for (const char* name : {"tum1.yaml", "tum2.yaml", "tum3.yaml", "7scenes.yaml"}) {
    EXPECT_NO_THROW(ReadSettings(data / "settings" / name)) << name;
  }
}

TEST(Settings, FormatReadRoundTrip) {
  testing::TempDir dir;
  Settings s;
  s.fx = 525.5;
  s.fy = 524.25;
  s.cx = 319.5;
  s.cy = 239.5;
  s.distortion.k1 = 0.125;
  s.width = 320;
  s.height = 240;
  s.orb.n_features = 500;
  s.depth_noise = {DepthNoise::Model::kQuadratic, 1.425e-3, 0.125};
  WriteSettings(dir / "s.yaml", s);
  const Settings r = ReadSettings(dir / "s.yaml");
  EXPECT_EQ(r.fx, s.fx);
  EXPECT_EQ(r.depth_noise.model, DepthNoise::Model::kQuadratic);
  EXPECT_EQ(r.depth_noise.k2, 1.425e-3);
  EXPECT_EQ(r.depth_noise.sampling, 0.125);
  EXPECT_EQ(r.cy, s.cy);
  EXPECT_EQ(r.distortion.k1, 0.125);
  EXPECT_EQ(r.width, 320);
  EXPECT_EQ(r.orb.n_features, 500);
  EXPECT_EQ(FormatSettings(r), FormatSettings(s));
}

TEST(Settings, DefaultsApplyToOptionalKeys) {
  testing::TempDir dir;
  testing::WriteTextFile(
      dir / "s.yaml",
      "%YAML:1.0\nCamera.fx: 500\nCamera.fy: 500\nCamera.cx: 320\nCamera.cy: 240\n");
  const Settings s = ReadSettings(dir / "s.yaml");
  EXPECT_TRUE(s.distortion.IsZero());
  EXPECT_EQ(s.width, 0);
  EXPECT_EQ(s.depth_map_factor, 5000.0);
  EXPECT_EQ(s.depth_noise.model, DepthNoise::Model::kOrbSlam2);
  EXPECT_EQ(s.depth_noise.DisparitySigma(s.bf), 0.0);
  EXPECT_EQ(FormatSettings(s).find("DepthNoise"), std::string::npos);
  EXPECT_EQ(s.orb.n_levels, 8);
}

void ExpectDataError(const std::string& text, const std::string& fragment) {
  testing::TempDir dir;
  testing::WriteTextFile(dir / "bad.yaml", text);
  try {
    ReadSettings(dir / "bad.yaml");
    FAIL() << "accepted: " << text;
  } catch (const DataError& e) {
    EXPECT_NE(std::string(e.what()).find("bad.yaml"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
  }
}

TEST(Settings, RejectsBadFiles) {
  const std::string intrinsics =
      "%YAML:1.0\nCamera.fx: 500\nCamera.fy: 500\nCamera.cx: 320\nCamera.cy: 240\n";
  ExpectDataError("", "empty");
  ExpectDataError("%YAML:1.0\nCamera.fy: 500\nCamera.cx: 320\nCamera.cy: 240\n",
                  "missing Camera.fx");
  ExpectDataError("%YAML:1.0\nCamera.fx: [1, 2\n", "not a valid YAML file: line 2");
  // OpenCV's parser throws std::length_error on an empty flow-map key.
  ExpectDataError("%YAML:1.0\nCamera.fx: 500\nx: { :y: 1 }\n", "not a valid YAML file (");
  ExpectDataError(intrinsics + "ORBextractor.nLevels: 0\n",
                  "ORBextractor.nLevels = 0; must be in [1, 16]");
  ExpectDataError(intrinsics + "Camera.width: 640.5\n", "Camera.width");
  ExpectDataError(intrinsics + "Camera.k1: abc\n", "Camera.k1 is not a number");
  testing::TempDir dir;
  EXPECT_THROW(ReadSettings(dir / "absent.yaml"), NoInputError);
}

// The depth model's keys; the older DepthDisparitySigma is the quadratic
// model with k2 = 0 and the same disparity sigma.
TEST(Settings, ReadsTheDepthNoiseModel) {
  const std::string intrinsics =
      "%YAML:1.0\nCamera.fx: 500\nCamera.fy: 500\nCamera.cx: 320\nCamera.cy: 240\n";
  testing::TempDir dir;
  auto read = [&](const std::string& keys) {
    testing::WriteTextFile(dir / "s.yaml", intrinsics + keys);
    return ReadSettings(dir / "s.yaml");
  };
  Settings s = read("DepthNoise.model: quadratic\nDepthNoise.k2: 1.5e-3\n");
  EXPECT_EQ(s.depth_noise.model, DepthNoise::Model::kQuadratic);
  EXPECT_NEAR(s.depth_noise.DisparitySigma(s.bf), 40 * 1.5e-3, 1e-15);  // bf = 40 by default.
  s = read("DepthNoise.model: quadratic\nDepthNoise.k2: 1.5e-3\nDepthNoise.sampling: 0.08\n");
  EXPECT_NEAR(s.depth_noise.DisparitySigma(40), 0.1, 1e-15);  // hypot(0.06, 0.08).
  s = read("DepthNoise.model: orbslam2\n");
  EXPECT_EQ(s.depth_noise.model, DepthNoise::Model::kOrbSlam2);
  s = read("DepthDisparitySigma: 0.115\n");
  EXPECT_EQ(s.depth_noise.model, DepthNoise::Model::kQuadratic);
  EXPECT_DOUBLE_EQ(s.depth_noise.DisparitySigma(s.bf), 0.115);
  EXPECT_EQ(read("DepthDisparitySigma: 0\n").depth_noise.model, DepthNoise::Model::kOrbSlam2);

  ExpectDataError(intrinsics + "DepthNoise.model: cubic\n",
                  "DepthNoise.model = cubic; must be orbslam2 or quadratic");
  ExpectDataError(intrinsics + "DepthNoise.k2: 1e-3\n", "need DepthNoise.model: quadratic");
  ExpectDataError(intrinsics + "DepthNoise.model: orbslam2\nDepthNoise.k2: 1e-3\n",
                  "takes no DepthNoise.k2");
  ExpectDataError(intrinsics + "DepthNoise.model: quadratic\n", "trusts depth without limit");
  ExpectDataError(intrinsics + "DepthNoise.model: quadratic\nDepthNoise.k2: -1e-3\n",
                  "DepthNoise.k2 = -0.001; must be >= 0");
  ExpectDataError(intrinsics + "DepthDisparitySigma: 0.1\nDepthNoise.model: quadratic\n",
                  "both DepthDisparitySigma and DepthNoise");
}

TEST(Settings, CheckNamesEachConstraint) {
  Settings base;
  base.fx = base.fy = 500;
  std::string why;
  EXPECT_TRUE(base.Check(&why)) << why;
  struct Case {
    void (*mutate)(Settings&);
    const char* fragment;
  };
  const Case cases[] = {
      {[](Settings& s) { s.fx = 0; }, "Camera.fx"},
      {[](Settings& s) { s.fy = -1; }, "Camera.fy"},
      {[](Settings& s) { s.width = -1; }, "Camera.width"},
      {[](Settings& s) { s.fps = 0; }, "Camera.fps"},
      {[](Settings& s) { s.bf = 0; }, "Camera.bf"},
      {[](Settings& s) { s.th_depth = 0; }, "ThDepth"},
      {[](Settings& s) { s.depth_map_factor = -5; }, "DepthMapFactor"},
      {[](Settings& s) {
         s.depth_noise = {DepthNoise::Model::kQuadratic, -1e-3, 0.1};
       },
       "DepthNoise.k2"},
      {[](Settings& s) {
         s.depth_noise = {DepthNoise::Model::kQuadratic, 1e-3, -0.1};
       },
       "DepthNoise.sampling"},
      {[](Settings& s) {
         s.depth_noise = {DepthNoise::Model::kQuadratic, 0, 0};
       },
       "without limit"},
      {[](Settings& s) { s.orb.n_features = 0; }, "nFeatures"},
      {[](Settings& s) { s.orb.scale_factor = 1.0; }, "scaleFactor"},
      {[](Settings& s) { s.orb.n_levels = 17; }, "nLevels"},
      {[](Settings& s) { s.orb.ini_th_fast = 0; }, "iniThFAST"},
      {[](Settings& s) { s.orb.min_th_fast = 30; }, "minThFAST"},
  };
  for (const Case& c : cases) {
    Settings s = base;
    c.mutate(s);
    EXPECT_FALSE(s.Check(&why)) << c.fragment;
    EXPECT_NE(why.find(c.fragment), std::string::npos) << why;
  }
}

TEST(Viewpoint, ReadsOrbSlam2ViewerKeys) {
  testing::TempDir dir;
  testing::WriteTextFile(
      dir / "v.yaml",
      "%YAML:1.0\nCamera.fx: 500\nViewer.ViewpointX: 0.5\nViewer.ViewpointY: -0.7\n"
      "Viewer.ViewpointZ: -1.8\nViewer.ViewpointF: 420\n");
  const Viewpoint v = ReadViewpoint(dir / "v.yaml");
  EXPECT_EQ(v.x, 0.5);
  EXPECT_EQ(v.y, -0.7);
  EXPECT_EQ(v.z, -1.8);
  EXPECT_EQ(v.f, 420);
  const auto message = [&](const std::string& text) {
    testing::WriteTextFile(dir / "w.yaml", text);
    try {
      ReadViewpoint(dir / "w.yaml");
    } catch (const DataError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(message("%YAML:1.0\nViewer.ViewpointX: 0\n").find("missing Viewer.ViewpointY"),
            std::string::npos);
  EXPECT_NE(message("%YAML:1.0\nViewer.ViewpointX: 0\nViewer.ViewpointY: 0\nViewer.ViewpointZ: -1\n"
                    "Viewer.ViewpointF: 0\n")
                .find("Viewer.ViewpointF = 0; must be > 0"),
            std::string::npos);
  EXPECT_NE(message("%YAML:1.0\nViewer.ViewpointX: 0\nViewer.ViewpointY: 0\nViewer.ViewpointZ: 0\n"
                    "Viewer.ViewpointF: 500\n")
                .find("is the origin"),
            std::string::npos);
  EXPECT_THROW(ReadViewpoint(dir / "none.yaml"), NoInputError);
  try {
    ReadSettings(dir.path());
    ADD_FAILURE() << "a folder was read as settings";
  } catch (const NoInputError& e) {
    EXPECT_NE(std::string(e.what()).find("is a folder, not a settings file"), std::string::npos);
  }
  EXPECT_THROW(ReadViewpoint(dir.path()), NoInputError);
}

TEST(Viewpoint, ParsesTextWithTheFileErrors) {
  const std::string text =
      "%YAML:1.0\nViewer.ViewpointX: 0.5\nViewer.ViewpointY: -0.7\nViewer.ViewpointZ: -1.8\n"
      "Viewer.ViewpointF: 420\n";
  const Viewpoint v = ParseViewpoint(text, "mem.yaml");
  EXPECT_EQ(v.x, 0.5);
  EXPECT_EQ(v.f, 420);
  testing::TempDir dir;
  testing::WriteTextFile(dir / "v.yaml", text);
  EXPECT_EQ(ReadViewpoint(dir / "v.yaml").z, v.z);
  for (const std::string& bad : {std::string(), std::string("%YAML:1.0\nViewer.ViewpointX: [\n"),
                                 std::string("%YAML:1.0\nViewer.ViewpointX: 1\n")}) {
    try {
      ParseViewpoint(bad, "mem.yaml");
      FAIL() << "accepted: " << bad;
    } catch (const DataError& e) {
      EXPECT_NE(std::string(e.what()).find("mem.yaml"), std::string::npos) << e.what();
    }
  }
}

// Found by common/fuzz/settings_fuzzer.cc: a coefficient of -0 was written
// as "-0", which reads back as the integer 0 (and is written as "0").
TEST(Settings, NegativeZeroIsWrittenAsZero) {
  const Settings s = ParseSettings(
      "%YAML:1.0\nCamera.fx: 500\nCamera.fy: 500\nCamera.cx: 320\nCamera.cy: 240\n"
      "Camera.p2: -0.0\n",
      "s.yaml");
  const std::string text = FormatSettings(s);
  EXPECT_NE(text.find("Camera.p2: 0\n"), std::string::npos) << text;
  EXPECT_EQ(FormatSettings(ParseSettings(text, "again.yaml")), text);
}

// Found by common/fuzz/settings_fuzzer.cc: OpenCV's YAML parser (4.6) never
// returned on some text that is not one map of keys at column 0 (a line
// left of an indented top-level collection, a second document); such text
// is now rejected before OpenCV sees it.
TEST(Settings, RejectsTextThatIsNotOneMapAtColumnZero) {
  const std::string intrinsics = "Camera.fx: 500\nCamera.fy: 500\nCamera.cx: 320\nCamera.cy: 240\n";
  const std::pair<std::string, std::string> cases[] = {
      {"%YAML:1.0\n----=\n----\n\n", "line 2: '----=' starts with '-'"},
      {"%YAML:1.0\n -%\n:#:-\n\n", "line 2: ' -%' is indented"},
      {"%YAML:1.0\n" + intrinsics + "---\nx: 1\n", "line 6: '---' starts with '-'"},
      {"%YAML:1.0\n- 1\n- 2\n", "line 2: '- 1' starts with '-'"},
      {"%YAML:1.0\n---\n---\n" + intrinsics, "line 3: '---' starts with '-'"},
      {"%YAML:1.0\n--- a: 1\n", "line 2: '--- a: 1' starts with '-'"},
      {"%YAML:1.0\n" + intrinsics + "...\n", "line 6: '...' ends the document"},
      {"%YAML:1.0\n  " + intrinsics, "line 2: '  Camera.fx: 500' is indented"}};
  for (const auto& [text, fragment] : cases) {
    try {
      ParseSettings(text, "s.yaml");
      FAIL() << "accepted: " << text;
    } catch (const DataError& e) {
      EXPECT_NE(std::string(e.what()).find("s.yaml: " + fragment), std::string::npos)
          << text << " -> " << e.what();
    }
    EXPECT_THROW(ParseViewpoint(text, "v.yaml"), DataError);
  }
  // One opening marker, indented comments, comments of dashes and nested
  // lists stay fine.
  EXPECT_EQ(
      ParseSettings("%YAML:1.0\n---  # start\n  # note\n#-----\n" + intrinsics + "list:\n  - 1\n",
                    "s.yaml")
          .fx,
      500);
}

// Found in review (issue 36): text nested tens of thousands of levels deep
// overflowed the stack in OpenCV's recursive YAML parser (exit 139), in
// settings and --viewpoint files alike. ParseYamlText now counts the depth
// first and refuses more than kMaxYamlNesting levels, flow or block.
TEST(Settings, RejectsYamlNestedTooDeep) {
  const size_t n = 100000;
  std::string maps, keys, dashes, tags;
  for (size_t i = 0; i < n; ++i) {
    maps += "{a: ";
    keys += "a: ";
    dashes += "- ";
    tags += "!!opencv-matrix [";
  }
  std::string indented = "Camera.fx:\n";  // One more block map per line.
  for (int i = 1; i <= 100; ++i) indented += std::string(i, ' ') + "a:\n";
  const std::pair<std::string, std::string> cases[] = {
      {"Camera.fx: " + std::string(n, '[') + std::string(n, ']') + "\n", "line 2"},
      {"Camera.fx: " + maps + "1" + std::string(n, '}') + "\n", "line 2"},
      {"Camera.fx: " + keys + "1\n", "line 2"},
      {"Camera.fx: " + dashes + "1\n", "line 2"},
      {"Camera.fx: " + tags + "\n", "line 2"},
      {"Camera.fx: [\n  " + std::string(n, '[') + "\n", "line 3"},
      {indented, "line 66"}};
  for (const auto& [body, line] : cases) {
    const std::string text = "%YAML:1.0\n" + body;
    for (const bool viewpoint : {false, true}) {
      try {
        viewpoint ? (void)ParseViewpoint(text, "s.yaml") : (void)ParseSettings(text, "s.yaml");
        FAIL() << "accepted: " << text.substr(0, 80);
      } catch (const DataError& e) {
        EXPECT_EQ(std::string(e.what()), "s.yaml: " + line + ": YAML nested deeper than " +
                                             std::to_string(kMaxYamlNesting) + " levels")
            << text.substr(0, 80);
      }
    }
  }
  // kMaxYamlNesting collections in all (the top-level map is one) pass.
  const auto nested = [](int levels) {
    return "%YAML:1.0\nCamera.fx: " + std::string(levels - 1, '[') + "1" +
           std::string(levels - 1, ']') + "\n";
  };
  EXPECT_NO_THROW(CheckYamlStructure(nested(kMaxYamlNesting), "s.yaml"));
  EXPECT_THROW(CheckYamlStructure(nested(kMaxYamlNesting + 1), "s.yaml"), DataError);
  // Brackets in quoted strings and keys, and comments, do not nest.
  EXPECT_NO_THROW(CheckYamlStructure("%YAML:1.0\nk[[: '" + std::string(200, '[') + "'\nc: [1, # " +
                                         std::string(200, '{') + "\n 2]\n",
                                     "s.yaml"));
}

// Issue 36: what OpenCV's parser reads wrongly without a word is refused.
TEST(Settings, RefusesDuplicateKeysAndIntegersThatWrap) {
  const std::pair<std::string, std::string> cases[] = {
      {"Camera.fx: 500\nCamera.fy: 500\nCamera.fx: 600\n",
       "s.yaml: line 4: key 'Camera.fx' is given twice"},
      {"ORBextractor.iniThFAST: 4294967316\n",
       "s.yaml: line 2: integer 4294967316 does not fit in 32 bits"},
      {"ORBextractor.iniThFAST: -2147483649\n",
       "s.yaml: line 2: integer -2147483649 does not fit in 32 bits"},
      {"Camera.fx: 500\nm: {a: 1, a: 2}\n", "s.yaml: line 3: key 'a' is given twice"},
      {"Camera.fx: 500\nm: !!int 99999999999999999999\n",
       "s.yaml: line 3: integer 99999999999999999999 does not fit in 32 bits"}};
  for (const auto& [body, message] : cases) {
    try {
      (void)ParseSettings("%YAML:1.0\n" + body, "s.yaml");
      FAIL() << "accepted: " << body;
    } catch (const DataError& e) {
      EXPECT_EQ(std::string(e.what()), message);
    }
  }
  // Equal keys in distinct maps, and the 32-bit limits themselves, pass.
  EXPECT_NO_THROW(CheckYamlStructure(
      "%YAML:1.0\na: {k: 2147483647}\nb: {k: -2147483648}\nc:\n  - {k: 1}\n  - {k: 2}\n",
      "s.yaml"));
}

}  // namespace
}  // namespace rrslam
