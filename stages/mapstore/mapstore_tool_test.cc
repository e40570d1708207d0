#include "stages/mapstore/mapstore_tool.h"

#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "common/atomic_file.h"
#include "common/binary_header.h"
#include "common/json_text.h"
#include "common/testing.h"
#include "stages/mapstore/map_file.h"
#include "stages/mapstore/map_test_util.h"

namespace rrslam {
namespace {

using testing::RunTool;
using testing::TempDir;

template <typename Options>
void ExpectCheckFails(const Options& o, const std::string& field) {
  std::string why;
  EXPECT_FALSE(o.Check(&why)) << field;
  EXPECT_NE(why.find(field), std::string::npos) << why;
}

TEST(MapstoreOptions, Checks) {
  std::string why;
  MapInfoOptions info;
  ExpectCheckFails(info, "map");
  info.map = "m.rrm";
  EXPECT_TRUE(info.Check(&why)) << why;
  MapVerifyOptions verify;
  ExpectCheckFails(verify, "map");
  verify.map = "m.rrm";
  EXPECT_TRUE(verify.Check(&why)) << why;
  MapDiffOptions diff;
  diff.a = "a.rrm";
  diff.b = "b.rrm";
  EXPECT_TRUE(diff.Check(&why)) << why;
  MapDiffOptions bad = diff;
  bad.a.clear();
  ExpectCheckFails(bad, "a:");
  bad = diff;
  bad.b.clear();
  ExpectCheckFails(bad, "b:");
  bad = diff;
  bad.radius = 0;
  ExpectCheckFails(bad, "radius");
  bad.radius = -0.1;
  ExpectCheckFails(bad, "radius");
}

class MapstoreTool : public ::testing::Test {
 protected:
  void SetUp() override {
    map_ = testing::MakeTestMap(31);
    WriteMapFile(dir_ / "a.rrm", map_);
  }
  // A copy of a.rrm with one byte of section `name` flipped.
  std::filesystem::path Corrupt(const std::string& name) {
    const std::string text = ReadFileToString(dir_ / "a.rrm");
    std::vector<uint8_t> bytes(text.begin(), text.end());
    const uint32_t header = LoadLittleEndian<uint32_t>(bytes.data() + 12);
    for (const MapSectionInfo& s : ReadMapFileInfo(bytes, "a.rrm").sections) {
      if (s.name == name) bytes[header + s.offset + s.size / 2] ^= 4;
    }
    const std::filesystem::path path = dir_ / ("bad-" + name + ".rrm");
    WriteFileAtomically(path, std::string(bytes.begin(), bytes.end()));
    return path;
  }
  TempDir dir_;
  MapData map_;
};

TEST_F(MapstoreTool, VerifyOk) {
  const auto r = RunTool("mapstore", "verify " + (dir_ / "a.rrm").string());
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("a.rrm: ok (12 keyframes, 100 map points)"), std::string::npos)
      << r.output;
}

TEST_F(MapstoreTool, VerifyCorruptMissingFolderUsage) {
  auto r = RunTool("mapstore", "verify " + Corrupt("observations").string());
  EXPECT_EQ(r.exit_code, 65) << r.output;
  EXPECT_NE(r.output.find("section observations: checksum mismatch (file corrupt)"),
            std::string::npos)
      << r.output;
  r = RunTool("mapstore", "verify " + (dir_ / "missing.rrm").string());
  EXPECT_EQ(r.exit_code, 66) << r.output;
  EXPECT_NE(r.output.find("missing.rrm: no such map file"), std::string::npos) << r.output;
  r = RunTool("mapstore", "verify " + dir_.path().string());
  EXPECT_EQ(r.exit_code, 66) << r.output;
  r = RunTool("mapstore", "");
  EXPECT_EQ(r.exit_code, 64) << r.output;
  r = RunTool("mapstore", "verify");
  EXPECT_EQ(r.exit_code, 64) << r.output;
  r = RunTool("mapstore", "frobnicate x");
  EXPECT_EQ(r.exit_code, 64) << r.output;
  r = RunTool("mapstore", "--help");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("65"), std::string::npos) << r.output;
}

TEST_F(MapstoreTool, Info) {
  auto r = RunTool("mapstore", "info " + (dir_ / "a.rrm").string() + " 2>&1");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  for (const std::string text :
       {"format: rrslam.map 2.0", "sections:", "keyframes: 12", "map_points: 100", "keypoints: 600",
        "loop_edges: 1", "tree: 0123456789abcdef", "name: voc.rrv", "bow_levels_up: 4",
        "mapstore test", "structure: ok", "descriptors"}) {
    EXPECT_NE(r.output.find(text), std::string::npos) << text << "\n" << r.output;
  }
  r = RunTool("mapstore", "info --json " + (dir_ / "a.rrm").string() + " 2>/dev/null");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const auto j = nlohmann::json::parse(r.output);
  EXPECT_EQ(j["counts"]["keyframes"], 12);
  EXPECT_EQ(j["sections"].size(), 10u);
  EXPECT_EQ(j["metadata"]["seed"], 31);
  EXPECT_EQ(j["camera"]["orb_levels"], 8);
}

// A map in a Latin-1 folder (legal on Linux, not UTF-8) whose metadata and
// vocabulary name hold such bytes too: info and diff print and write them
// (common/json_text.h) instead of failing with nlohmann's type_error 316.
TEST_F(MapstoreTool, NamesAndMetadataThatAreNotUtf8) {
  const std::filesystem::path dir = dir_ / "caf\xe9";
  std::filesystem::create_directories(dir);
  MapData map = map_;
  map.metadata = "{\"sequence\": \"/data/caf\xe9\"}";
  map.vocabulary.name = "voc\xe9.rrv";
  WriteMapFile(dir / "a.rrm", map);
  const std::string a = testing::Quote(dir / "a.rrm");
  auto r = RunTool("mapstore", "info --json " + a + " 2>/dev/null");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const auto j = nlohmann::json::parse(r.output);
  EXPECT_EQ(PathFromJson(j["file"].get<std::string>()), dir / "a.rrm");
  EXPECT_EQ(UnquoteJsonString(j["metadata"].get<std::string>()), map.metadata);
  EXPECT_EQ(UnquoteJsonString(j["vocabulary"]["name"].get<std::string>()), "voc\xe9.rrv");
  r = RunTool("mapstore", "info " + a);
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("structure: ok"), std::string::npos) << r.output;
  r = RunTool("mapstore", "diff " + testing::Quote(dir_ / "a.rrm") + " " + a + " --json " +
                              testing::Quote(dir / "diff.json"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const auto diff = nlohmann::json::parse(ReadFileToString(dir / "diff.json"));
  EXPECT_EQ(PathFromJson(diff["b"].get<std::string>()), dir / "a.rrm");
}

TEST_F(MapstoreTool, InfoOnCorruptSection) {
  auto r = RunTool("mapstore", "info " + Corrupt("keypoints").string());
  EXPECT_EQ(r.exit_code, 65) << r.output;
  EXPECT_NE(r.output.find("MISMATCH"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("keyframes: 12"), std::string::npos) << r.output;  // Meta is intact.
  EXPECT_NE(r.output.find("section keypoints: checksum mismatch"), std::string::npos) << r.output;
  r = RunTool("mapstore", "info " + Corrupt("meta").string());
  EXPECT_EQ(r.exit_code, 65) << r.output;
  EXPECT_NE(r.output.find("counts: unavailable"), std::string::npos) << r.output;
}

TEST_F(MapstoreTool, Diff) {
  MapData b = map_;
  testing::RemoveTestPoint(&b, map_.map_points[7].id);
  const double p[3] = {50, 50, 50};
  const uint64_t added = testing::AddTestPoint(&b, p);
  testing::AddTestKeyframe(&b);
  WriteMapFile(dir_ / "b.rrm", b);
  const auto out = dir_ / "diff.json";
  auto r = RunTool("mapstore", "diff " + (dir_ / "a.rrm").string() + " " +
                                   (dir_ / "b.rrm").string() + " --json " + out.string());
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("map points: 100 -> 100: 1 added, 1 removed"), std::string::npos)
      << r.output;
  EXPECT_NE(r.output.find("keyframes: 12 -> 13: 1 added, 0 removed"), std::string::npos)
      << r.output;
  const auto j = nlohmann::json::parse(ReadFileToString(out));
  EXPECT_EQ(j["map_points"]["added_count"], 1);
  EXPECT_EQ(j["map_points"]["added"][0]["id"], added);
  EXPECT_EQ(j["map_points"]["added"][0]["position"][0], 50.0);
  EXPECT_EQ(j["map_points"]["removed"][0]["id"], map_.map_points[7].id);
  EXPECT_EQ(j["keyframes"]["added"].size(), 1u);
  EXPECT_EQ(j["radius_m"], 0.05);
  r = RunTool("mapstore", "diff " + (dir_ / "a.rrm").string() + " " + (dir_ / "b.rrm").string() +
                              " --radius -1");
  EXPECT_EQ(r.exit_code, 64) << r.output;
  r = RunTool("mapstore", "diff " + (dir_ / "a.rrm").string() + " " + (dir_ / "nope.rrm").string());
  EXPECT_EQ(r.exit_code, 66) << r.output;
  r = RunTool("mapstore", "diff " + (dir_ / "a.rrm").string() + " " + (dir_ / "b.rrm").string() +
                              " --json " + (dir_ / "no" / "d.json").string());
  EXPECT_EQ(r.exit_code, 73) << r.output;
}

}  // namespace
}  // namespace rrslam
