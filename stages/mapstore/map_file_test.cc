#include "stages/mapstore/map_file.h"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iterator>
#include <limits>
#include <sstream>

#include "common/binary_header.h"
#include "common/errors.h"
#include "common/formats.h"
#include "common/testing.h"
#include "stages/mapstore/map_test_util.h"

namespace rrslam {
namespace {

using testing::MakeTestMap;
using testing::TempDir;
using testing::TestMapOptions;

template <typename... Args>
std::string Cat(const Args&... args) {
  std::ostringstream s;
  (s << ... << args);
  return s.str();
}

void ExpectMapsEqual(const MapData& a, const MapData& b) {
  EXPECT_EQ(a.camera, b.camera);
  EXPECT_TRUE(a.vocabulary.SameTree(b.vocabulary));
  EXPECT_EQ(a.vocabulary.name, b.vocabulary.name);
  EXPECT_EQ(a.bow_levels_up, b.bow_levels_up);
  EXPECT_EQ(a.next_keyframe_id, b.next_keyframe_id);
  EXPECT_EQ(a.next_map_point_id, b.next_map_point_id);
  EXPECT_EQ(a.metadata, b.metadata);
  ASSERT_EQ(a.keyframes.size(), b.keyframes.size());
  for (size_t i = 0; i < a.keyframes.size(); ++i) {
    const KeyFrameRecord& x = a.keyframes[i];
    const KeyFrameRecord& y = b.keyframes[i];
    EXPECT_EQ(x.id, y.id);
    EXPECT_EQ(x.frame_id, y.frame_id);
    EXPECT_EQ(x.timestamp, y.timestamp);
    EXPECT_EQ(x.T_cam_world, y.T_cam_world);
    EXPECT_EQ(x.keypoints, y.keypoints);
    EXPECT_EQ(x.descriptors, y.descriptors);
    EXPECT_EQ(x.map_point_ids, y.map_point_ids);
    EXPECT_EQ(x.bow, y.bow);
    EXPECT_EQ(x.feature_vector, y.feature_vector);
    EXPECT_EQ(x.connections, y.connections);
    EXPECT_EQ(x.parent, y.parent);
    EXPECT_EQ(x.loop_edges, y.loop_edges);
  }
  ASSERT_EQ(a.map_points.size(), b.map_points.size());
  for (size_t i = 0; i < a.map_points.size(); ++i) {
    const MapPointRecord& x = a.map_points[i];
    const MapPointRecord& y = b.map_points[i];
    EXPECT_EQ(x.id, y.id);
    for (int k = 0; k < 3; ++k) {
      EXPECT_EQ(x.position[k], y.position[k]);
      EXPECT_EQ(x.normal[k], y.normal[k]);
    }
    EXPECT_EQ(x.min_distance, y.min_distance);
    EXPECT_EQ(x.max_distance, y.max_distance);
    EXPECT_EQ(x.descriptor, y.descriptor);
    EXPECT_EQ(x.visible, y.visible);
    EXPECT_EQ(x.found, y.found);
    EXPECT_EQ(x.reference_keyframe, y.reference_keyframe);
    EXPECT_EQ(x.first_keyframe, y.first_keyframe);
    EXPECT_EQ(x.observations, y.observations);
  }
}

// Expects `f` to throw an Error of type E whose message contains `text`.
template <typename E = DataError, typename F>
void ExpectError(F&& f, const std::string& text) {
  try {
    f();
    ADD_FAILURE() << "no error; expected one containing: " << text;
  } catch (const E& e) {
    EXPECT_NE(std::string(e.what()).find(text), std::string::npos)
        << "message: " << e.what() << "\nexpected: " << text;
  }
}

void ExpectParseError(const std::vector<uint8_t>& file, const std::string& text) {
  ExpectError([&] { ParseMap(file, "map.rrm"); }, text);
}

// Recomputes every checksum of a file (sections, payload, header) after an
// edit, as a writer with that content would have; `minor` sets the version.
void Reseal(std::vector<uint8_t>* file, uint16_t minor = kMapFormat.minor) {
  const uint32_t header_size = LoadLittleEndian<uint32_t>(file->data() + 12);
  std::vector<uint8_t> fields(file->begin() + kBaseHeaderSize, file->begin() + header_size);
  const std::span<const uint8_t> payload(file->data() + header_size, file->size() - header_size);
  const uint32_t count = LoadLittleEndian<uint32_t>(fields.data());
  for (uint32_t i = 0; i < count; ++i) {
    uint8_t* e = fields.data() + 8 + 40 * i;
    const uint64_t offset = LoadLittleEndian<uint64_t>(e + 16);
    const uint64_t size = LoadLittleEndian<uint64_t>(e + 24);
    if (offset > payload.size() || size > payload.size() - offset) continue;
    StoreLittleEndian<uint64_t>(e + 32, Checksum64(payload.subspan(offset, size)));
  }
  FormatSpec spec = kMapFormat;
  spec.minor = minor;
  const std::vector<uint8_t> header = BuildBinaryHeader(spec, fields, payload);
  ASSERT_EQ(header.size(), header_size);
  std::memcpy(file->data(), header.data(), header_size);
}

// Payload offset of section `name` in an encoded file.
MapSectionInfo Section(const std::vector<uint8_t>& file, const std::string& name) {
  for (const MapSectionInfo& s : ReadMapFileInfo(file, "map.rrm").sections) {
    if (s.name == name) return s;
  }
  ADD_FAILURE() << "no section " << name;
  return {};
}

uint32_t HeaderSize(const std::vector<uint8_t>& file) {
  return LoadLittleEndian<uint32_t>(file.data() + 12);
}

// ---------------------------------------------------------------------------
// Round trips

TEST(MapFile, RoundTripEqual) {
  const MapData map = MakeTestMap(1);
  ASSERT_NO_THROW(ValidateMapData(map, "test map"));
  MapFileInfo info;
  const MapData back = ParseMap(EncodeMap(map), "map.rrm", &info);
  ExpectMapsEqual(map, back);
  EXPECT_EQ(info.major, 2);
  EXPECT_EQ(info.minor, 0);
  ASSERT_EQ(info.sections.size(), 10u);
  EXPECT_EQ(info.sections[0].name, "meta");
  EXPECT_EQ(info.sections[3].name, "descriptors");
  for (const MapSectionInfo& s : info.sections) {
    EXPECT_EQ(s.offset % (s.name == "descriptors" ? 32 : 8), 0u) << s.name;
  }
}

// Each keyframe's entries follow the previous keyframe's in the concatenated
// arrays: keyframes of different sizes, and with no feature-vector groups or
// bag of words among others, must not shift anything.
TEST(MapFile, RoundTripEqualWithKeyframesOfEveryShape) {
  TestMapOptions options;
  options.keyframes = 40;
  options.keypoints = 300;
  options.map_points = 1500;
  for (const bool with_empty_records : {false, true}) {
    MapData map = MakeTestMap(31, options);
    // Feature vectors that differ from keyframe to keyframe (i + 2 groups).
    for (size_t i = 0; i < map.keyframes.size(); ++i) {
      KeyFrameRecord& kf = map.keyframes[i];
      kf.feature_vector.assign(i + 2, {});
      for (uint32_t g = 0; g < i + 2; ++g) kf.feature_vector[g].first = 100 + g;
      for (uint32_t k = 0; k < kf.keypoints.size(); ++k) {
        kf.feature_vector[k % (i + 2)].second.push_back(k);
      }
    }
    if (with_empty_records) {
      for (size_t i : {0, 7, 8, 39}) {
        map.keyframes[i].feature_vector.clear();
        map.keyframes[i].bow.clear();
      }
      map.keyframes[5].feature_vector[0].second.clear();
    }
    ASSERT_NO_THROW(ValidateMapData(map, "test map"));
    const MapData back = ParseMap(EncodeMap(map), "map.rrm", nullptr);
    ExpectMapsEqual(map, back);
  }
}

TEST(MapFile, EncodingIsDeterministic) {
  const MapData map = MakeTestMap(2);
  const std::vector<uint8_t> a = EncodeMap(map);
  const std::vector<uint8_t> b = EncodeMap(MakeTestMap(2));
  EXPECT_EQ(a, b);
  EXPECT_EQ(EncodeMap(ParseMap(a, "a")), a);
  EXPECT_NE(EncodeMap(MakeTestMap(3)), a);
}

TEST(MapFile, EmptyMapRoundTrip) {
  MapData map;
  map.metadata = "{}";
  const MapData back = ParseMap(EncodeMap(map), "empty.rrm");
  ExpectMapsEqual(map, back);
}

// The streamed file holds EncodeMap's bytes, across many 4 MB pieces, and
// the header it reports is the one a reader finds.
TEST(MapFile, StreamedFileIsTheEncodedBytes) {
  TempDir dir;
  TestMapOptions options;
  options.keyframes = 150;
  options.keypoints = 1000;
  options.map_points = 15000;
  const MapData map = MakeTestMap(5, options);
  const MapFileInfo written = WriteMapFileAt(dir / "map.rrm", map, "map.rrm");
  std::ifstream in(dir / "map.rrm", std::ios::binary);
  const std::vector<uint8_t> bytes((std::istreambuf_iterator<char>(in)), {});
  const std::vector<uint8_t> encoded = EncodeMap(map);
  ASSERT_GT(encoded.size(), size_t{12} << 20);
  EXPECT_TRUE(bytes == encoded);
  const MapFileInfo read = ReadMapFileInfo(bytes, "map.rrm");
  EXPECT_EQ(written.major, read.major);
  EXPECT_EQ(written.minor, read.minor);
  EXPECT_EQ(written.file_size, read.file_size);
  ASSERT_EQ(written.sections.size(), read.sections.size());
  for (size_t i = 0; i < read.sections.size(); ++i) {
    EXPECT_EQ(written.sections[i].name, read.sections[i].name);
    EXPECT_EQ(written.sections[i].offset, read.sections[i].offset);
    EXPECT_EQ(written.sections[i].size, read.sections[i].size);
    EXPECT_EQ(written.sections[i].checksum, read.sections[i].checksum);
  }
}

TEST(MapFile, WriteReadFile) {
  TempDir dir;
  const MapData map = MakeTestMap(4);
  WriteMapFile(dir / "map.rrm", map);
  EXPECT_EQ(testing::TemporaryLeftovers(dir), std::vector<std::string>{});
  MapFileInfo info;
  ExpectMapsEqual(map, ReadMapFile(dir / "map.rrm", &info));
  EXPECT_EQ(info.file_size, std::filesystem::file_size(dir / "map.rrm"));
  ExpectError<CantCreateError>([&] { WriteMapFile(dir / "no" / "map.rrm", map); }, "no");
}

// A map read from a file views the file's keypoints, descriptors and map
// point ids (record_array.h); a new map saved over the path (a rename) leaves
// them as read, and an edit copies only the edited array.
TEST(MapFile, ReadKeyframesViewTheFileAndOutliveItsReplacement) {
  TempDir dir;
  const MapData map = MakeTestMap(4);
  WriteMapFile(dir / "map.rrm", map);
  MapData read = ReadMapFile(dir / "map.rrm");
  ASSERT_FALSE(read.keyframes.empty());
  for (const KeyFrameRecord& kf : read.keyframes) {
    EXPECT_TRUE(kf.keypoints.is_view());
    EXPECT_TRUE(kf.descriptors.is_view());
    EXPECT_TRUE(kf.map_point_ids.is_view());
  }
  WriteMapFile(dir / "map.rrm", MakeTestMap(5));
  ExpectMapsEqual(map, read);
  read.keyframes[0].map_point_ids[0] = kNoId;
  EXPECT_FALSE(read.keyframes[0].map_point_ids.is_view());
  EXPECT_TRUE(read.keyframes[0].keypoints.is_view());
  EXPECT_EQ(read.keyframes[1].map_point_ids, map.keyframes[1].map_point_ids);
  // Parsed from bytes in memory, nothing is viewed.
  const MapData copied = ParseMap(EncodeMap(map), "bytes");
  EXPECT_FALSE(copied.keyframes[0].keypoints.is_view());
  EXPECT_FALSE(copied.keyframes[0].descriptors.is_view());
  ExpectMapsEqual(map, copied);
}

TEST(MapFile, MetaAlone) {
  const MapData map = MakeTestMap(5);
  MapCounts c;
  const MapData meta = ParseMapMeta(EncodeMap(map), "map.rrm", &c);
  EXPECT_EQ(meta.camera, map.camera);
  EXPECT_EQ(meta.vocabulary.name, "voc.rrv");
  EXPECT_EQ(meta.metadata, map.metadata);
  EXPECT_TRUE(meta.keyframes.empty());
  EXPECT_EQ(c.keyframes, 12u);
  EXPECT_EQ(c.map_points, map.map_points.size());
  EXPECT_EQ(c.keypoints, 12u * 50);
  EXPECT_EQ(c.loop_edges, 2u);
}

// ---------------------------------------------------------------------------
// Rejected corruptions

TEST(MapFile, RejectsTruncated) {
  const std::vector<uint8_t> file = EncodeMap(MakeTestMap(6));
  const size_t header = HeaderSize(file);
  for (size_t length : {size_t{0}, size_t{5}, size_t{39}, size_t{40}, header - 1, header,
                        header + 100, file.size() / 2, file.size() - 1}) {
    SCOPED_TRACE(length);
    ExpectParseError({file.begin(), file.begin() + length}, "truncated");
  }
}

TEST(MapFile, RejectsBadMagic) {
  std::vector<uint8_t> file = EncodeMap(MakeTestMap(7));
  file[0] = 'X';
  ExpectParseError(file, "map.rrm: not an rrslam map (bad magic)");
  const std::vector<uint8_t> vocab_magic = {'R', 'R', 'S', 'L', 'V', 'O', 'C', 'B', 1, 0};
  ExpectParseError(vocab_magic, "bad magic");
}

TEST(MapFile, RejectsFutureMajor) {
  std::vector<uint8_t> file = EncodeMap(MakeTestMap(8));
  StoreLittleEndian<uint16_t>(file.data() + 8, 3);
  ExpectParseError(file, "map.rrm: format major version 3, this build reads 1 and 2");
}

TEST(MapFile, AcceptsNewerMinorWithUnknownSectionAndFields) {
  const MapData map = MakeTestMap(9);
  const std::vector<uint8_t> old = EncodeMap(map);
  const uint32_t header_size = HeaderSize(old);
  // A 1.2 file: one more section ("extra", 24 bytes at the end of the
  // payload) and 16 bytes of new header fields after the table.
  std::vector<uint8_t> fields(old.begin() + kBaseHeaderSize, old.begin() + header_size);
  const uint32_t count = LoadLittleEndian<uint32_t>(fields.data());
  std::vector<uint8_t> entry(40, 0);
  std::memcpy(entry.data(), "extra", 5);
  std::vector<uint8_t> payload(old.begin() + header_size, old.end());
  StoreLittleEndian<uint64_t>(entry.data() + 16, payload.size());
  StoreLittleEndian<uint64_t>(entry.data() + 24, 24);
  payload.insert(payload.end(), 24, 0xab);
  fields.insert(fields.begin() + 8 + 40 * count, entry.begin(), entry.end());
  StoreLittleEndian<uint32_t>(fields.data(), count + 1);
  fields.insert(fields.end(), 16, 0x5a);
  std::vector<uint8_t> file(kBaseHeaderSize + fields.size(), 0);
  file.insert(file.end(), payload.begin(), payload.end());
  StoreLittleEndian<uint32_t>(file.data() + 12,
                              static_cast<uint32_t>(kBaseHeaderSize + fields.size()));
  std::memcpy(file.data() + kBaseHeaderSize, fields.data(), fields.size());
  Reseal(&file, 2);
  MapFileInfo info;
  const MapData back = ParseMap(file, "newer.rrm", &info);
  EXPECT_EQ(info.minor, 2);
  EXPECT_EQ(info.sections.size(), 11u);
  EXPECT_EQ(info.sections.back().name, "extra");
  ExpectMapsEqual(map, back);
}

TEST(MapFile, RejectsFlippedBitInEachSection) {
  const std::vector<uint8_t> file = EncodeMap(MakeTestMap(10));
  const size_t header = HeaderSize(file);
  const MapFileInfo info = ReadMapFileInfo(file, "map.rrm");
  ASSERT_EQ(info.sections.size(), 10u);
  for (const MapSectionInfo& s : info.sections) {
    SCOPED_TRACE(s.name);
    ASSERT_GT(s.size, 0u);
    std::vector<uint8_t> bad = file;
    bad[header + s.offset + s.size / 2] ^= 0x10;
    ExpectParseError(bad, "map.rrm: section " + s.name + ": checksum mismatch (file corrupt)");
  }
}

// Since format 1.1: maps kept beside the map (an atlas session that never
// merged).
MapData MapWithOtherMaps() {
  MapData map = MakeTestMap(11);
  map.other_maps.push_back(MakeTestMap(12));
  map.other_maps.push_back(MakeTestMap(13));
  return map;
}

TEST(MapFile, OtherMapsRoundTrip) {
  const MapData map = MapWithOtherMaps();
  MapFileInfo info;
  const MapData back = ParseMap(EncodeMap(map), "atlas.rrm", &info);
  EXPECT_EQ(info.major, 2);
  ASSERT_EQ(info.sections.size(), 30u);
  EXPECT_EQ(info.sections[10].name, "1:meta");
  EXPECT_EQ(info.sections[23].name, "2:desc");
  EXPECT_EQ(info.sections[23].offset % 32, 0u);
  ExpectMapsEqual(map, back);
  ASSERT_EQ(back.other_maps.size(), 2u);
  ExpectMapsEqual(map.other_maps[0], back.other_maps[0]);
  ExpectMapsEqual(map.other_maps[1], back.other_maps[1]);
  MapData alone = map;
  alone.other_maps.clear();
  EXPECT_EQ(ReadMapFileInfo(EncodeMap(alone), "alone.rrm").sections.size(), 10u);
}

// Format 2.0's records: a keypoint is a Keypoint's 32 bytes (read in
// place from a mapped file), a bag-of-words entry (word, value) and an
// observation (keyframe, keypoint) 12 bytes each, packed.
TEST(MapFile, FormatTwoRecordSizes) {
  const MapData map = MakeTestMap(21);
  uint64_t keypoints = 0, bow_entries = 0, observations = 0;
  for (const KeyFrameRecord& kf : map.keyframes) {
    keypoints += kf.keypoints.size();
    bow_entries += kf.bow.size();
  }
  for (const MapPointRecord& p : map.map_points) observations += p.observations.size();
  const std::vector<uint8_t> file = EncodeMap(map);
  EXPECT_EQ(Section(file, "keypoints").size, 32 * keypoints);
  EXPECT_EQ(Section(file, "bow").size, 12 * bow_entries);
  EXPECT_EQ(Section(file, "observations").size, 12 * observations);
  const MapSectionInfo kp = Section(file, "keypoints");
  const Keypoint& first = map.keyframes[0].keypoints[0];
  const uint8_t* record = file.data() + HeaderSize(file) + kp.offset;
  EXPECT_EQ(LoadLittleEndian<float>(record + 16), first.angle_deg);
  EXPECT_EQ(record[20], first.octave);
  EXPECT_EQ(LoadLittleEndian<float>(record + 28), first.depth);
  const MapSectionInfo bow = Section(file, "bow");
  const auto& [word, value] = map.keyframes[0].bow[1];
  const uint8_t* entry = file.data() + HeaderSize(file) + bow.offset + 12;
  EXPECT_EQ(LoadLittleEndian<uint32_t>(entry), word);
  EXPECT_EQ(LoadLittleEndian<double>(entry + 4), value);
}

// Files of format 1.0 and 1.1 (stages/mapstore/testdata: MakeTestMap(7),
// and with MakeTestMap(8) of 5 keyframes and 30 points beside it, written
// by the 1.x writer of 2026-12-05) read as the maps they hold, u_right
// dropped; saved again they are format 2.0 and smaller.
TEST(MapFile, ReadsFormatOneFiles) {
  const std::filesystem::path dir = testing::SourceDir() / "stages/mapstore/testdata";
  MapFileInfo info;
  const MapData one = ReadMapFile(dir / "format-1.0.rrm", &info);
  EXPECT_EQ(info.major, 1);
  EXPECT_EQ(info.minor, 0);
  ExpectMapsEqual(MakeTestMap(7), one);
  const MapData atlas = ReadMapFile(dir / "format-1.1.rrm", &info);
  EXPECT_EQ(info.minor, 1);
  ExpectMapsEqual(MakeTestMap(7), atlas);
  ASSERT_EQ(atlas.other_maps.size(), 1u);
  TestMapOptions o;
  o.keyframes = 5;
  o.map_points = 30;
  ExpectMapsEqual(MakeTestMap(8, o), atlas.other_maps[0]);
  const std::vector<uint8_t> again = EncodeMap(one);
  EXPECT_EQ(ReadMapFileInfo(again, "again.rrm").major, 2);
  EXPECT_LT(again.size(), std::filesystem::file_size(dir / "format-1.0.rrm"));
  ExpectMapsEqual(one, ParseMap(again, "again.rrm"));
}

TEST(MapFile, RejectsFlippedBitInAnOtherMapsSection) {
  const std::vector<uint8_t> file = EncodeMap(MapWithOtherMaps());
  const MapSectionInfo s = Section(file, "2:obs");
  std::vector<uint8_t> bad = file;
  bad[HeaderSize(file) + s.offset + s.size / 2] ^= 0x10;
  ExpectParseError(bad, "map.rrm: section 2:obs: checksum mismatch (file corrupt)");
}

TEST(MapFile, RejectsAnOtherMapOfAnotherCameraOrVocabulary) {
  MapData map = MapWithOtherMaps();
  map.other_maps[1].camera.fx += 1;
  ExpectParseError(EncodeMap(map),
                   "map.rrm (other map 2): another camera, vocabulary or BoW "
                   "grouping than the map's");
  map = MapWithOtherMaps();
  map.other_maps[0].vocabulary.content_hash ^= 1;
  EXPECT_THROW(ValidateMapData(map, "m"), DataError);
  map = MapWithOtherMaps();
  map.other_maps[0].other_maps.push_back(MakeTestMap(14));
  EXPECT_THROW(ValidateMapData(map, "m"), DataError);
}

TEST(MapFile, RejectsCorruptPadding) {
  std::vector<uint8_t> file = EncodeMap(MakeTestMap(11));
  const MapSectionInfo meta = Section(file, "meta");
  const MapSectionInfo next = Section(file, "keyframes");
  ASSERT_LT(meta.offset + meta.size, next.offset) << "the test needs padding after meta";
  file[HeaderSize(file) + meta.offset + meta.size] = 1;
  ExpectParseError(file, "payload checksum mismatch outside the known sections");
}

TEST(MapFile, RejectsBadHeaderChecksum) {
  std::vector<uint8_t> file = EncodeMap(MakeTestMap(12));
  file[kBaseHeaderSize + 8 + 40 + 24] ^= 1;  // Size of the second section.
  ExpectParseError(file, "header checksum mismatch");
}

TEST(MapFile, RejectsSectionOutsidePayload) {
  std::vector<uint8_t> file = EncodeMap(MakeTestMap(13));
  StoreLittleEndian<uint64_t>(file.data() + kBaseHeaderSize + 8 + 40 * 2 + 24, 1ull << 60);
  Reseal(&file);
  ExpectParseError(file, "section keypoints: bytes");
}

TEST(MapFile, RejectsMissingSection) {
  std::vector<uint8_t> file = EncodeMap(MakeTestMap(14));
  std::memcpy(file.data() + kBaseHeaderSize + 8 + 40 * 7, "grapx", 5);
  Reseal(&file);
  ExpectParseError(file, "map.rrm: section graph is missing");
}

TEST(MapFile, RejectsCountsThatDoNotMatchSections) {
  // Consistent checksums, inconsistent content: the counts are checked
  // against the sections before anything is allocated.
  const std::vector<uint8_t> file = EncodeMap(MakeTestMap(15));
  const size_t meta = HeaderSize(file) + Section(file, "meta").offset;
  for (uint64_t count : {uint64_t{13}, uint64_t{1} << 40, ~uint64_t{0}}) {
    std::vector<uint8_t> bad = file;
    StoreLittleEndian<uint64_t>(bad.data() + meta + 192, count);  // Keyframes.
    Reseal(&bad);
    ExpectParseError(bad, "map.rrm: section keyframes: ");
  }
  std::vector<uint8_t> bad = file;
  const size_t kf = HeaderSize(file) + Section(file, "keyframes").offset;
  StoreLittleEndian<uint32_t>(bad.data() + kf + 88, 51);  // First keyframe's keypoints.
  Reseal(&bad);
  ExpectParseError(bad, "records list 601 keypoints in total, section meta says 600");
  bad = file;
  StoreLittleEndian<uint64_t>(bad.data() + meta + 264, 1ull << 62);  // Name length.
  Reseal(&bad);
  ExpectParseError(bad, "section meta: strings");
}

// Next ids index arrays when track loads the map (map_data.h): one read
// from a file is bounded by the counts before anything is allocated for it,
// and verify (ParseMap) refuses what loading would refuse, naming the field.
TEST(MapFile, RejectsNextIdsAboveTheBound) {
  const MapData map = MakeTestMap(15);
  const std::vector<uint8_t> file = EncodeMap(map);
  const size_t meta = HeaderSize(file) + Section(file, "meta").offset;
  const uint64_t kf_bound = MaxNextMapId(map.keyframes.size());
  const uint64_t mp_bound = MaxNextMapId(map.map_points.size());
  EXPECT_EQ(kf_bound, (uint64_t{1} << 24) + 64 * map.keyframes.size());
  for (uint64_t next : {kf_bound + 1, uint64_t{100000000}, uint64_t{4600000000000000000}}) {
    std::vector<uint8_t> bad = file;
    StoreLittleEndian<uint64_t>(bad.data() + meta + 176, next);  // next_keyframe_id
    Reseal(&bad);
    ExpectParseError(bad, "map.rrm: section meta: next_keyframe_id " + std::to_string(next) +
                              " is above " + std::to_string(kf_bound));
    bad = file;
    StoreLittleEndian<uint64_t>(bad.data() + meta + 184, next + mp_bound - kf_bound);
    Reseal(&bad);
    ExpectParseError(bad, "map.rrm: section meta: next_map_point_id ");
  }
  // The bound itself is a valid map.
  std::vector<uint8_t> edge = file;
  StoreLittleEndian<uint64_t>(edge.data() + meta + 176, kf_bound);
  StoreLittleEndian<uint64_t>(edge.data() + meta + 184, mp_bound);
  Reseal(&edge);
  EXPECT_EQ(ParseMap(edge, "map.rrm").next_map_point_id, mp_bound);
  EXPECT_EQ(MaxNextMapId(~uint64_t{0}), ~uint64_t{0});  // Saturates.
}

// A map padded far beyond the size its header gives (here 256 MB, sparse) is
// refused from its header, before the mapping that pre-faults every page
// reads it all (an 8 GB one made verify and --load-map touch 8 GB).
TEST(MapFile, PaddedFileIsRefusedBeforeItsPagesAreRead) {
  TempDir dir;
  const std::filesystem::path path = dir / "padded.rrm";
  WriteMapFile(path, MakeTestMap(17));
  std::filesystem::resize_file(path, uint64_t{256} << 20);
  if (!testing::ResetPeakResident()) GTEST_SKIP() << "cannot reset the peak resident size";
  const long before = testing::PeakResidentKb();
  ExpectError([&] { ReadMapFile(path); }, "padded.rrm: truncated or padded");
  EXPECT_LT(testing::PeakResidentKb() - before, 64 * 1024) << "kB read into memory";
}

TEST(MapFile, RejectsRelationViolationInFile) {
  MapData map = MakeTestMap(16);
  map.keyframes[2].parent = 12345;
  ExpectParseError(EncodeMap(map), "map.rrm: keyframe 7: parent keyframe 12345 is not in the map");
}

TEST(MapFile, FolderAndMissingFileAreNoInput) {
  TempDir dir;
  ExpectError<NoInputError>([&] { ReadMapFile(dir.path()); }, "is a folder");
  ExpectError<NoInputError>([&] { ReadMapFile(dir / "missing.rrm"); },
                            "missing.rrm: no such map file");
  testing::WriteTextFile(dir / "empty.rrm", "");
  ExpectError<DataError>([&] { ReadMapFile(dir / "empty.rrm"); }, "empty.rrm: truncated");
}

// ---------------------------------------------------------------------------
// ValidateMapData: one test per relation

class Validate : public ::testing::Test {
 protected:
  void SetUp() override {
    map_ = MakeTestMap(21);
    ASSERT_NO_THROW(ValidateMapData(map_, "m"));
  }
  void Expect(const std::string& text) {
    ExpectError([&] { ValidateMapData(map_, "m"); }, "m: " + text);
  }
  KeyFrameRecord& Kf(size_t i) { return map_.keyframes[i]; }
  // The first (keyframe index, keypoint) with a map point.
  std::pair<size_t, uint32_t> Observed() {
    for (size_t i = 0; i < map_.keyframes.size(); ++i) {
      for (uint32_t k = 0; k < Kf(i).map_point_ids.size(); ++k) {
        if (Kf(i).map_point_ids[k] != kNoId) return {i, k};
      }
    }
    return {0, 0};
  }
  MapPointRecord& Point(uint64_t id) {
    for (MapPointRecord& p : map_.map_points) {
      if (p.id == id) return p;
    }
    throw std::logic_error("no point");
  }
  MapData map_;
};

TEST_F(Validate, EmptyMapIsValid) { EXPECT_NO_THROW(ValidateMapData(MapData{}, "m")); }

TEST_F(Validate, KeyframeIdsSortedAndUnique) {
  std::swap(map_.keyframes[3], map_.keyframes[4]);
  Expect("keyframe ids not sorted and unique: keyframe 10 follows keyframe 13");
}

TEST_F(Validate, MapPointIdsSortedAndUnique) {
  map_.map_points[5].id = map_.map_points[4].id;
  Expect("map point ids not sorted and unique: map point 22 follows map point 22");
}

TEST_F(Validate, NextIdsAboveEveryId) {
  map_.next_keyframe_id = Kf(11).id;
  Expect("keyframe 34: id not below next_keyframe_id 34");
  map_ = MakeTestMap(21);
  map_.next_map_point_id = 3;
  Expect("map point 7: id not below next_map_point_id 3");
}

TEST_F(Validate, ParallelArrays) {
  Kf(2).descriptors.pop_back();
  Expect("keyframe 7: 50 keypoints but 49 descriptors and 50 map point ids");
  map_ = MakeTestMap(21);
  Kf(2).map_point_ids.push_back(kNoId);
  Expect("keyframe 7: 50 keypoints but 50 descriptors and 51 map point ids");
}

TEST_F(Validate, FiniteValues) {
  Kf(1).T_cam_world.tx = std::nan("");
  Expect("keyframe 4: pose T_cam_world is not finite");
  map_ = MakeTestMap(21);
  Kf(1).timestamp = std::numeric_limits<double>::infinity();
  Expect("keyframe 4: timestamp is not finite");
  map_ = MakeTestMap(21);
  Kf(1).keypoints[3].depth = std::numeric_limits<float>::infinity();
  Expect("keyframe 4 keypoint 3: a value is not finite");
  map_ = MakeTestMap(21);
  map_.map_points[2].position[1] = std::nan("");
  Expect("map point 12: position or normal is not finite");
}

TEST_F(Validate, UnitQuaternion) {
  Kf(0).T_cam_world.qw *= 1 + 1e-5;
  Expect("keyframe 1: pose quaternion has norm");
  map_ = MakeTestMap(21);
  Kf(0).T_cam_world.qw *= 1 + 1e-8;  // Within 1e-6.
  EXPECT_NO_THROW(ValidateMapData(map_, "m"));
}

TEST_F(Validate, OctaveBelowOrbLevels) {
  Kf(5).keypoints[7].octave = 8;
  Expect("keyframe 16 keypoint 7: octave 8 not below the camera's ORB levels 8");
}

TEST_F(Validate, KeyframePointExists) {
  const auto [i, k] = Observed();
  Kf(i).map_point_ids[k] = 999999;
  Expect(Cat("keyframe ", Kf(i).id, " keypoint ", k,
             " has map point 999999, which is not in the map"));
}

// Ids the lookup's bitmap (one bit per id below next_map_point_id, in words
// of 64) holds no bit for: the first id of the word after its last, and a
// gap below the next id.
TEST_F(Validate, KeyframePointBeyondTheIdsIsNotInTheMap) {
  const auto [i, k] = Observed();
  const uint64_t past = (map_.next_map_point_id + 63) / 64 * 64;
  Kf(i).map_point_ids[k] = past;
  Expect(Cat("keyframe ", Kf(i).id, " keypoint ", k, " has map point ", past,
             ", which is not in the map"));
  map_.next_map_point_id = past + 1;
  Expect(Cat("keyframe ", Kf(i).id, " keypoint ", k, " has map point ", past,
             ", which is not in the map"));
}

TEST_F(Validate, KeyframePointListsObservationBack) {
  // A keypoint without a map point is given a point that does not list it.
  const size_t i = Observed().first;
  uint32_t k = 0;
  while (Kf(i).map_point_ids[k] != kNoId) ++k;
  for (const MapPointRecord& p : map_.map_points) {
    bool sees = false;
    for (const auto& o : p.observations) sees |= o.first == Kf(i).id;
    if (sees) continue;
    Kf(i).map_point_ids[k] = p.id;
    Expect(Cat("keyframe ", Kf(i).id, " keypoint ", k, " has map point ", p.id, " but map point ",
               p.id, " does not list keyframe ", Kf(i).id, " keypoint ", k));
    return;
  }
  FAIL() << "no point without an observation of keyframe " << Kf(i).id;
}

TEST_F(Validate, ObservationListedByKeyframe) {
  // Point P lists (K, I) but K's keypoint I has point Q (which lists (K, I)).
  const auto [i, k] = Observed();
  const uint64_t p_id = Kf(i).map_point_ids[k];
  for (MapPointRecord& q : map_.map_points) {
    if (q.id <= p_id) continue;
    bool sees = false;
    for (const auto& o : q.observations) sees |= o.first == Kf(i).id;
    if (sees) continue;
    q.observations.push_back({Kf(i).id, k});
    std::sort(q.observations.begin(), q.observations.end());
    Kf(i).map_point_ids[k] = q.id;
    Expect(Cat("map point ", p_id, " lists keyframe ", Kf(i).id, " keypoint ", k, " but keyframe ",
               Kf(i).id, " keypoint ", k, " has map point ", q.id));
    return;
  }
  FAIL() << "no suitable second point";
}

TEST_F(Validate, ObservationKeyframeExistsAndIndexInRange) {
  // The keyframe forgets the point (so its own check passes) and the point
  // names a keypoint out of range.
  MapPointRecord& p = map_.map_points[0];
  const uint64_t kf = p.observations.back().first;
  for (KeyFrameRecord& k : map_.keyframes) {
    if (k.id == kf) k.map_point_ids[p.observations.back().second] = kNoId;
  }
  p.observations.back().second = 50;
  Expect("map point 2 lists keyframe " + std::to_string(kf) + " keypoint 50 but keyframe " +
         std::to_string(kf) + " has 50 keypoints");
  map_ = MakeTestMap(21);
  map_.map_points[0].observations.push_back({1000, 0});
  Expect("map point 2 lists keyframe 1000, which is not in the map");
}

TEST_F(Validate, ObservationsSorted) {
  MapPointRecord& p = map_.map_points[0];
  ASSERT_GE(p.observations.size(), 2u);
  std::swap(p.observations[0], p.observations[1]);
  Expect("map point 2: observations not sorted by keyframe id and unique");
}

TEST_F(Validate, ReferenceKeyframeObservesPoint) {
  MapPointRecord& p = map_.map_points[3];
  p.reference_keyframe = 1000;
  Expect("map point 17: reference keyframe 1000 does not observe it");
}

TEST_F(Validate, BowSortedAndWordsInVocabulary) {
  std::swap(Kf(0).bow[0], Kf(0).bow[1]);
  Expect("keyframe 1: bag of words not sorted by word");
  map_ = MakeTestMap(21);
  Kf(0).bow.push_back({1000000, 0.5});
  Expect("keyframe 1: bag of words has word 1000000, not below the 1000000 words");
  map_ = MakeTestMap(21);
  Kf(0).bow[0].second = std::nan("");
  Expect("keyframe 1: bag of words value of word");
}

TEST_F(Validate, FeatureVectorSortedAndInRange) {
  Kf(1).feature_vector[2].second.push_back(50);
  Expect("keyframe 4: feature vector node 102 has keypoint 50, not below its 50 keypoints");
  map_ = MakeTestMap(21);
  std::swap(Kf(1).feature_vector[0], Kf(1).feature_vector[1]);
  Expect("keyframe 4: feature vector not sorted by node");
  map_ = MakeTestMap(21);
  std::swap(Kf(1).feature_vector[0].second[0], Kf(1).feature_vector[0].second[1]);
  Expect("keyframe 4: feature vector node 100 keypoint indices not sorted");
}

TEST_F(Validate, CovisibilitySymmetric) {
  KeyFrameRecord& a = Kf(0);
  ASSERT_FALSE(a.connections.empty());
  const uint64_t b = a.connections[0].first;
  a.connections[0].second += 1;
  Expect("covisibility not symmetric: keyframe 1 lists keyframe " + std::to_string(b) +
         " with weight");
  map_ = MakeTestMap(21);
  for (KeyFrameRecord& kf : map_.keyframes) {
    if (kf.id == b) std::erase_if(kf.connections, [](const auto& c) { return c.first == 1; });
  }
  Expect("covisibility not symmetric: keyframe 1 lists keyframe " + std::to_string(b) + " (weight");
  map_ = MakeTestMap(21);
  Kf(0).connections.push_back({5000, 3});
  Expect("keyframe 1: connected to keyframe 5000, which is not in the map");
  map_ = MakeTestMap(21);
  std::reverse(Kf(0).connections.begin(), Kf(0).connections.end());
  Expect("keyframe 1: connections not sorted by id and unique");
}

TEST_F(Validate, LoopEdgesSymmetric) {
  Kf(11).loop_edges.clear();
  Expect(
      "loop edges not symmetric: keyframe 4 lists keyframe 34 but keyframe 34 does not list "
      "keyframe 4");
  map_ = MakeTestMap(21);
  Kf(1).loop_edges.push_back(5000);
  Expect("keyframe 4: loop edge to keyframe 5000, which is not in the map");
}

TEST_F(Validate, SpanningTree) {
  Kf(3).parent = 5000;
  Expect("keyframe 10: parent keyframe 5000 is not in the map");
  map_ = MakeTestMap(21);
  Kf(4).parent = kNoId;
  Expect("spanning tree has more than one root: keyframe 1 and keyframe 13 have no parent");
  map_ = MakeTestMap(21);
  Kf(0).parent = Kf(1).id;
  Expect("spanning tree has no root");
  map_ = MakeTestMap(21);
  Kf(1).parent = Kf(2).id;  // 4 -> 7 -> 4, while 1 stays the root.
  Kf(2).parent = Kf(1).id;
  Expect("spanning tree has a cycle through keyframe");
  map_ = MakeTestMap(21);
  Kf(1).parent = Kf(1).id;
  Expect("keyframe 4: its own spanning-tree parent");
}

// ---------------------------------------------------------------------------
// Timing printout (not an assertion: timing goals belong to benchmarks).

TEST(MapFile, PrintsLargeMapTiming) {
  testing::TestMapOptions o;
  o.keyframes = 150;
  o.keypoints = 1000;
  o.map_points = 15000;
  o.min_observations = 2;
  o.max_observations = 10;
  o.bow_words = 600;
  const MapData map = MakeTestMap(17, o);
  TempDir dir;
  using Clock = std::chrono::steady_clock;
  auto ms = [](Clock::time_point t) {
    return std::chrono::duration<double, std::milli>(Clock::now() - t).count();
  };
  double encode = 1e9, write = 1e9, parse = 1e9, read = 1e9, validate = 1e9, checksum = 1e9;
  std::vector<uint8_t> bytes;
  for (int rep = 0; rep < 3; ++rep) {
    auto t = Clock::now();
    bytes = EncodeMap(map);
    encode = std::min(encode, ms(t));
    t = Clock::now();
    WriteMapFile(dir / "big.rrm", map);
    write = std::min(write, ms(t));
    t = Clock::now();
    const MapData back = ParseMap(bytes, "big.rrm");
    parse = std::min(parse, ms(t));
    t = Clock::now();
    ValidateMapData(back, "big.rrm");
    validate = std::min(validate, ms(t));
    t = Clock::now();
    volatile uint64_t sum = Checksum64(bytes);
    (void)sum;
    checksum = std::min(checksum, ms(t));
    t = Clock::now();
    const MapData again = ReadMapFile(dir / "big.rrm");
    read = std::min(read, ms(t));
    ASSERT_EQ(again.map_points.size(), map.map_points.size());
  }
  uint64_t observations = 0;
  for (const auto& p : map.map_points) observations += p.observations.size();
  std::printf(
      "[timing] 150 KF x 1000 keypoints, %zu map points, %llu observations: %.1f MB; "
      "EncodeMap %.1f ms, WriteMapFile (encode + fsync) %.1f ms, ParseMap (+validate) %.1f ms, "
      "ReadMapFile %.1f ms (best of 3; of ParseMap: ValidateMapData %.1f ms, one XXH3 pass "
      "%.1f ms)\n",
      map.map_points.size(), static_cast<unsigned long long>(observations), bytes.size() / 1e6,
      encode, write, parse, read, validate, checksum);
}

// Writes the fuzz seed corpus when RRSLAM_MAPSTORE_WRITE_SEEDS names a folder.
TEST(MapFile, WriteFuzzSeeds) {
  const char* dir = std::getenv("RRSLAM_MAPSTORE_WRITE_SEEDS");
  if (dir == nullptr) GTEST_SKIP() << "set RRSLAM_MAPSTORE_WRITE_SEEDS to write the seeds";
  testing::TestMapOptions o;
  o.keyframes = 3;
  o.keypoints = 4;
  o.map_points = 3;
  o.min_observations = 1;
  o.max_observations = 2;
  o.bow_words = 2;
  WriteMapFile(std::filesystem::path(dir) / "small.rrm", MakeTestMap(1, o));
  WriteMapFile(std::filesystem::path(dir) / "empty.rrm", MapData{});
  MapData atlas = MakeTestMap(1, o);
  atlas.other_maps.push_back(MakeTestMap(2, o));
  WriteMapFile(std::filesystem::path(dir) / "atlas.rrm", atlas);
}

}  // namespace
}  // namespace rrslam
