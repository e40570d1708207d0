// End to end: how the benchmarks find a real sequence by name
// (bench/real_sequences.mk, `make bench-real-sequences`), on a shared-data
// folder made up in a temporary directory.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>

#include "common/testing.h"

namespace rrslam {
namespace {

namespace fs = std::filesystem;

using testing::Quote;
using testing::SourceDir;

// A sequence folder with `frames` lines in rgb.txt (and a comment line).
void MakeSequence(const fs::path& dir, int frames, bool with_settings = false) {
  fs::create_directories(dir);
  std::ofstream rgb(dir / "rgb.txt");
  rgb << "# timestamp filename\n";
  for (int i = 0; i < frames; ++i) rgb << i << ".0 rgb/" << i << ".png\n";
  if (with_settings) std::ofstream(dir / "settings.yaml") << "%YAML:1.0\n";
}

class RealSequencesTest : public ::testing::Test {
 protected:
  void SetUp() override {
    shared_ = dir_.path() / "data";
    fs::create_directories(shared_ / "settings");
    for (const char* s : {"tum1.yaml", "tum2.yaml", "tum3.yaml", "7scenes.yaml"}) {
      std::ofstream(shared_ / "settings" / s) << "%YAML:1.0\n";
    }
  }

  // NAME -> "folder settings frames", as `make bench-real-sequences` prints.
  std::map<std::string, std::string> Resolve(const std::string& names,
                                             const std::string& extra = "") {
    const auto r = testing::RunCommand(
        "env -u MAKEFLAGS -u MFLAGS -u MAKELEVEL make --no-print-directory -C " +
        Quote(SourceDir()) + " bench-real-sequences SHARED_DATA=" + Quote(shared_) +
        " BENCH_REAL=\"" + names + "\" " + extra);
    EXPECT_EQ(r.exit_code, 0) << r.output;
    std::map<std::string, std::string> out;
    std::istringstream lines(r.output);
    std::string line;
    while (std::getline(lines, line)) {
      const size_t space = line.find(' ');
      if (space != std::string::npos) out[line.substr(0, space)] = line.substr(space + 1);
    }
    return out;
  }

  testing::TempDir dir_;
  fs::path shared_;
};

TEST_F(RealSequencesTest, FindsFoldersAndSettingsByName) {
  MakeSequence(shared_ / "tum" / "fr1_xyz", 12);
  MakeSequence(shared_ / "tum" / "rgbd_dataset_freiburg2_desk", 7);
  MakeSequence(shared_ / "fr3_office", 5, /*with_settings=*/true);
  MakeSequence(shared_ / "7scenes-kitchen", 4, /*with_settings=*/true);
  MakeSequence(shared_ / "7scenes-chess", 3);
  MakeSequence(shared_ / "plain", 2);
  MakeSequence(dir_.path() / "elsewhere" / "mine", 6);
  const std::string s = shared_.string();
  const auto r =
      Resolve("fr1_xyz fr2_desk fr3_office 7scenes-kitchen 7scenes-chess plain mine gone",
              "bench_real_dir.mine=" + Quote(dir_.path() / "elsewhere" / "mine"));
  // TUM camera from the name; TUM's full folder name; the folder's own settings.
  EXPECT_EQ(r.at("fr1_xyz"), s + "/tum/fr1_xyz " + s + "/settings/tum1.yaml 12");
  EXPECT_EQ(r.at("fr2_desk"),
            s + "/tum/rgbd_dataset_freiburg2_desk " + s + "/settings/tum2.yaml 7");
  EXPECT_EQ(r.at("fr3_office"), s + "/fr3_office " + s + "/fr3_office/settings.yaml 5");
  // The kitchen keeps the settings file the benches always named.
  EXPECT_EQ(r.at("7scenes-kitchen"), s + "/7scenes-kitchen " + s + "/settings/7scenes.yaml 4");
  EXPECT_EQ(r.at("7scenes-chess"), s + "/7scenes-chess " + s + "/settings/7scenes.yaml 3");
  // No settings to be found: the benches' vocabulary step will say so.
  EXPECT_EQ(r.at("plain"), s + "/plain - 2");
  // A folder given by bench_real_dir.NAME.
  EXPECT_EQ(r.at("mine"), (dir_.path() / "elsewhere" / "mine").string() + " - 6");
  EXPECT_EQ(r.at("gone"), "- - -");
}

}  // namespace
}  // namespace rrslam
