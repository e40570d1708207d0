#include "common/trajectory.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "common/atomic_file.h"
#include "common/errors.h"
#include "common/testing.h"
#include "common/text.h"

namespace rrslam {
namespace {

TEST(Trajectory, ParsesTumLinesWithCommentsAndSeparators) {
  const Trajectory t = ParseTumTrajectory(
      "# ground truth\n\n1305031449.7996 1.2334 -0.0113 1.6941 0.7907 0.4393 -0.1770 -0.3879\n"
      "1.5,1,2,3,0,0,0,2\n2.5\t0\t0\t0\t0\t0\t0\t1\r\n",
      "gt.txt");
  ASSERT_EQ(t.size(), 3u);
  EXPECT_DOUBLE_EQ(t[0].timestamp, 1305031449.7996);
  EXPECT_DOUBLE_EQ(t[0].T_world_cam.translation.z(), 1.6941);
  EXPECT_NEAR(t[0].T_world_cam.rotation.norm(), 1.0, 1e-12);  // Normalized.
  EXPECT_DOUBLE_EQ(t[1].T_world_cam.rotation.w(), 1.0);       // (0,0,0,2) -> identity.
  EXPECT_DOUBLE_EQ(t[2].timestamp, 2.5);
}

TEST(Trajectory, WritesSixAndNineDecimals) {
  Trajectory t(1);
  t[0].timestamp = 1305031453.3596845;
  t[0].T_world_cam.translation = {1.0, -0.5, 0.25};
  EXPECT_EQ(FormatTumTrajectory(t),
            "1305031453.359684 1.000000000 -0.500000000 0.250000000 0.000000000 0.000000000 "
            "0.000000000 1.000000000\n");
}

TEST(Trajectory, FileRoundTrip) {
  testing::TempDir dir;
  Trajectory t;
  for (int i = 0; i < 10; ++i) {
    StampedPose p;
    p.timestamp = 100 + i / 30.0;
    p.T_world_cam = Rigid3d(ExpSO3({0.01 * i, -0.02 * i, 0.3}), {0.1 * i, 2.0, -0.5 * i});
    t.push_back(p);
  }
  WriteTumTrajectory(dir / "t.txt", t);
  const Trajectory r = ReadTumTrajectory(dir / "t.txt");
  ASSERT_EQ(r.size(), t.size());
  for (size_t i = 0; i < t.size(); ++i) {
    EXPECT_NEAR(r[i].timestamp, t[i].timestamp, 1e-6);
    EXPECT_LT((r[i].T_world_cam.translation - t[i].T_world_cam.translation).norm(), 1e-8);
    EXPECT_LT(RotationAngle(r[i].T_world_cam.rotation, t[i].T_world_cam.rotation), 1e-8);
  }
}

TEST(Trajectory, RejectsMalformedLines) {
  EXPECT_THROW(ParseTumTrajectory("1 2 3\n", "t.txt"), DataError);
  EXPECT_THROW(ParseTumTrajectory("1 2 3 4 5 6 7 x\n", "t.txt"), DataError);
  EXPECT_THROW(ParseTumTrajectory("1 2 3 4 0 0 0 0\n", "t.txt"), DataError);
  try {
    ParseTumTrajectory("# c\n1 0 0 0 0 0 0 1\n2 0 0 nan 0 0 0 1\n", "t.txt");
    FAIL();
  } catch (const DataError& e) {
    EXPECT_NE(std::string(e.what()).find("t.txt line 3"), std::string::npos) << e.what();
  }
  testing::TempDir dir;
  EXPECT_THROW(ReadTumTrajectory(dir / "absent.txt"), NoInputError);
}

TEST(Trajectory, ReadsSharedGroundTruth) {
  RRSLAM_REQUIRE_SHARED_DATA(data);
  const Trajectory gt = ReadTumTrajectory(data / "tum" / "fr1_desk" / "groundtruth.txt");
  EXPECT_EQ(gt.size(), 2335u);
}

// Found with common/fuzz/trajectory_fuzzer.cc's round-trip property: a line
// longer than the 256-byte buffer (fixed notation of 1e300 has 300 digits)
// was cut, losing its newline and fields, and did not read back.
TEST(Trajectory, LongLinesAreWrittenWhole) {
  Trajectory t(2);
  t[0].timestamp = -kMaxTimestamp;
  t[0].T_world_cam.translation = {-1e300, 2.5, 1e250};
  t[1].timestamp = 2;
  const std::string text = FormatTumTrajectory(t);
  EXPECT_EQ(std::count(text.begin(), text.end(), '\n'), 2) << text;
  const Trajectory r = ParseTumTrajectory(text, "t.txt");
  ASSERT_EQ(r.size(), 2u);
  EXPECT_EQ(r[0].timestamp, -kMaxTimestamp);
  EXPECT_EQ(r[0].T_world_cam.translation.x(), -1e300);
  EXPECT_EQ(r[1].timestamp, 2);
  EXPECT_EQ(FormatTumTrajectory(r), text);
  // A timestamp beyond is refused (issue 36), not written as 300 digits.
  t[0].timestamp = 1e300;
  EXPECT_THROW(ParseTumTrajectory(FormatTumTrajectory(t), "t.txt"), DataError);
}

// Found with common/fuzz/trajectory_fuzzer.cc's unit-quaternion property:
// components whose squares overflow (1e200) normalized to a zero quaternion.
TEST(Trajectory, QuaternionsWithHugeComponentsNormalize) {
  const Trajectory t = ParseTumTrajectory("1 0 0 0 1e200 0 0 1e200\n", "t.txt");
  ASSERT_EQ(t.size(), 1u);
  EXPECT_NEAR(t[0].T_world_cam.rotation.norm(), 1.0, 1e-12);
  EXPECT_NEAR(t[0].T_world_cam.rotation.x(), std::sqrt(0.5), 1e-12);
  EXPECT_NEAR(t[0].T_world_cam.rotation.w(), std::sqrt(0.5), 1e-12);
}

}  // namespace
}  // namespace rrslam
