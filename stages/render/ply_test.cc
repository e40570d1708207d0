#include "stages/render/ply.h"

#include <gtest/gtest.h>

#include "common/atomic_file.h"
#include "common/errors.h"
#include "common/testing.h"

namespace rrslam {
namespace {

PlyCloud SampleCloud() {
  PlyCloud cloud;
  cloud.positions = {{0.5f, -1.25f, 3.0f}, {1e-3f, 2.0f, -0.125f}, {7.0f, 8.0f, 9.0f}};
  cloud.normals = {{0, 0, 1}, {0, -1, 0}, {1, 0, 0}};
  cloud.colors = {{255, 0, 0}, {0, 128, 255}, {1, 2, 3}};
  cloud.observations = {2, 17, 5};
  cloud.triangles = {{0, 1, 2}};
  cloud.comments = {"producer test"};
  return cloud;
}

void ExpectSame(const PlyCloud& a, const PlyCloud& b) {
  ASSERT_EQ(a.positions.size(), b.positions.size());
  for (size_t i = 0; i < a.positions.size(); ++i) {
    EXPECT_EQ(a.positions[i], b.positions[i]) << i;  // Exact: %.9g round-trips floats.
    EXPECT_EQ(a.normals[i], b.normals[i]) << i;
    EXPECT_EQ(a.colors[i], b.colors[i]) << i;
    EXPECT_EQ(a.observations[i], b.observations[i]) << i;
  }
  EXPECT_EQ(a.triangles, b.triangles);
  EXPECT_EQ(a.comments, b.comments);
}

TEST(Ply, AsciiAndBinaryRoundTrip) {
  const PlyCloud cloud = SampleCloud();
  for (PlyFormat format : {PlyFormat::kAscii, PlyFormat::kBinaryLittleEndian}) {
    const std::string bytes = EncodePly(cloud, format);
    ExpectSame(cloud, ParsePly(bytes, "cloud.ply"));
  }
  const std::string ascii = EncodePly(cloud, PlyFormat::kAscii);
  EXPECT_NE(ascii.find("format ascii 1.0\n"), std::string::npos);
  EXPECT_NE(ascii.find("element vertex 3\n"), std::string::npos);
  EXPECT_NE(ascii.find("property uchar red\n"), std::string::npos);
  EXPECT_NE(ascii.find("property int scalar_observations\n"), std::string::npos);
  EXPECT_NE(ascii.find("element face 1\nproperty list uchar int vertex_indices\n"),
            std::string::npos);
}

TEST(Ply, PositionsOnlyAndWriteRead) {
  rrslam::testing::TempDir dir;
  PlyCloud cloud;
  cloud.positions = {{1, 2, 3}};
  WritePly(dir.path() / "p.ply", cloud, PlyFormat::kBinaryLittleEndian);
  const PlyCloud back = ReadPly(dir.path() / "p.ply");
  ASSERT_EQ(back.positions.size(), 1u);
  EXPECT_EQ(back.positions[0], Eigen::Vector3f(1, 2, 3));
  EXPECT_TRUE(back.colors.empty());
  EXPECT_TRUE(back.normals.empty());
}

TEST(Ply, ReadsForeignPropertyOrderAndTypes) {
  // As other tools write them: double positions, extra properties, other order.
  const std::string text =
      "ply\nformat ascii 1.0\nelement vertex 2\nproperty uchar red\nproperty uchar green\n"
      "property uchar blue\nproperty float64 x\nproperty float64 y\nproperty float64 z\n"
      "property float intensity\nend_header\n10 20 30 1.5 2.5 3.5 0.1\n40 50 60 -1 -2 -3 0.2\n";
  const PlyCloud cloud = ParsePly(text, "foreign.ply");
  ASSERT_EQ(cloud.positions.size(), 2u);
  EXPECT_EQ(cloud.positions[1], Eigen::Vector3f(-1, -2, -3));
  EXPECT_EQ(cloud.colors[0], (std::array<uint8_t, 3>{10, 20, 30}));
}

TEST(Ply, MalformedFilesNameTheFileAndProblem) {
  const std::string good = EncodePly(SampleCloud(), PlyFormat::kBinaryLittleEndian);
  const auto message = [](const std::string& bytes) {
    try {
      ParsePly(bytes, "bad.ply");
    } catch (const DataError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(message("").find("bad.ply: not a readable PLY file: no PLY header"), std::string::npos);
  EXPECT_NE(message(good.substr(0, good.size() - 20)).find("bad.ply"), std::string::npos);
  EXPECT_NE(message("ply\nformat binary_big_endian 1.0\nelement vertex 0\nend_header\n")
                .find("unsupported format 'binary_big_endian'"),
            std::string::npos);
  EXPECT_NE(message("ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nend_header\n1\n")
                .find("without x, y, z"),
            std::string::npos);
  EXPECT_NE(message("ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\n"
                    "property float z\nend_header\n1 2 3\n")
                .find("vertex 1 of 2 is short"),
            std::string::npos);
  EXPECT_NE(message("ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
                    "property float z\nelement face 1\nproperty list uchar int vertex_indices\n"
                    "end_header\n1 2 3\n3 0 0 5\n")
                .find("face index 5 out of range"),
            std::string::npos);
  EXPECT_THROW(ReadPly("/nonexistent/x.ply"), NoInputError);
}

TEST(Ply, RefusesInconsistentClouds) {
  PlyCloud cloud = SampleCloud();
  cloud.colors.pop_back();
  EXPECT_THROW(EncodePly(cloud, PlyFormat::kAscii), std::invalid_argument);
  cloud = SampleCloud();
  cloud.triangles = {{0, 1, 3}};
  EXPECT_THROW(EncodePly(cloud, PlyFormat::kAscii), std::invalid_argument);
}

}  // namespace
}  // namespace rrslam
