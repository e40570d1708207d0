#include "stages/mapstore/map_compose.h"

#include <gtest/gtest.h>

#include <bit>

#include "common/errors.h"
#include "stages/mapstore/map_file.h"
#include "stages/mapstore/map_test_util.h"

namespace rrslam {
namespace {

using testing::MakeTestMap;

int BitsDiffering(const OrbDescriptor& a, const OrbDescriptor& b) {
  int bits = 0;
  for (int i = 0; i < 32; ++i)
    bits += std::popcount(static_cast<unsigned>(a.bytes[i] ^ b.bytes[i]));
  return bits;
}

// A 1000-keyframe map composed of 100 copies of a 10-keyframe one: a valid
// map, every copy in its place and told apart by its descriptors, and its
// file read back gives the same bytes when written again.
TEST(ComposeMapTest, ThousandKeyFramesValidDistinctAndRoundTripByteForByte) {
  testing::TestMapOptions small;
  small.keyframes = 10;
  small.keypoints = 30;
  small.map_points = 60;
  const MapData base = MakeTestMap(7, small);
  ComposeOptions options;
  options.copies = 100;
  options.spacing = 15;
  int rebagged = 0;
  const MapData big = ComposeMap(base, options, [&](KeyFrameRecord*) { ++rebagged; });
  ASSERT_EQ(big.keyframes.size(), 1000u);
  ASSERT_EQ(big.map_points.size(), 100 * base.map_points.size());
  EXPECT_EQ(rebagged, 990);
  ValidateMapData(big, "composed");
  // Copy 11 (grid of 10 a side: column 1, row 1) sits 15 m along x and z.
  const size_t copy = 11, n = base.map_points.size(), k = base.keyframes.size();
  for (size_t i = 0; i < n; ++i) {
    const MapPointRecord& p = big.map_points[copy * n + i];
    EXPECT_NEAR(p.position[0], base.map_points[i].position[0] + 15, 1e-9);
    EXPECT_NEAR(p.position[1], base.map_points[i].position[1], 1e-9);
    EXPECT_NEAR(p.position[2], base.map_points[i].position[2] + 15, 1e-9);
  }
  // Copy 0 is the base; the others' descriptors differ in up to 64 bits.
  EXPECT_EQ(big.keyframes[0].descriptors[0], base.keyframes[0].descriptors[0]);
  int changed = 0;
  for (size_t j = 0; j < base.keyframes[0].descriptors.size(); ++j) {
    const int bits =
        BitsDiffering(big.keyframes[copy * k].descriptors[j], base.keyframes[0].descriptors[j]);
    EXPECT_LE(bits, 64);
    changed += bits > 40 ? 1 : 0;
  }
  EXPECT_EQ(changed, static_cast<int>(base.keyframes[0].descriptors.size()));
  const std::vector<uint8_t> bytes = EncodeMap(big);
  const MapData back = ParseMap(bytes, "composed.rrm");
  EXPECT_EQ(EncodeMap(back), bytes);
}

TEST(ComposeMapTest, OneCopyIsTheBaseAndNoneIsRefused) {
  const MapData base = MakeTestMap(3);
  ComposeOptions options;
  options.copies = 1;
  EXPECT_EQ(EncodeMap(ComposeMap(base, options)), EncodeMap(base));
  options.copies = 0;
  EXPECT_THROW(ComposeMap(base, options), DataError);
}

}  // namespace
}  // namespace rrslam
