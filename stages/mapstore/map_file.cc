#include "stages/mapstore/map_file.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <system_error>

#include "common/atomic_file.h"
#include "common/binary_header.h"
#include "common/errors.h"
#include "common/formats.h"
#include "common/heap_reserve.h"
#include "common/path_check.h"

namespace rrslam {
namespace {

// ---------------------------------------------------------------------------
// Layout constants (docs/mapstore.md describes every field).

// Format-specific header fields: uint32 section count, uint32 reserved, then
// the section table.
constexpr size_t kTableStart = 8;
constexpr size_t kSectionNameSize = 16;
constexpr size_t kSectionEntrySize = 40;  // name[16], offset, size, checksum.

enum Section : int {
  kMeta,
  kKeyframes,
  kKeypoints,
  kDescriptors,
  kKfPoints,
  kBow,
  kFeatureVectors,
  kGraph,
  kMapPoints,
  kObservations,
  kNumSections
};
constexpr std::array<const char*, kNumSections> kSectionNames = {
    "meta", "keyframes",       "keypoints", "descriptors", "kf_points",
    "bow",  "feature_vectors", "graph",     "map_points",  "observations"};

// Alignment of each section's offset in the payload. Descriptors go to 32 so
// that a reader mapping the file can use them in place.
constexpr uint64_t SectionAlignment(int section) { return section == kDescriptors ? 32 : 8; }

constexpr size_t kMetaFixedSize = 280;
constexpr size_t kKeyframeRecordSize = 112;
constexpr size_t kKeypointRecordSize = 36;
constexpr size_t kDescriptorSize = 32;
constexpr size_t kBowEntrySize = 16;
constexpr size_t kFvGroupSize = 8;
constexpr size_t kFvIndexSize = 4;
constexpr size_t kConnectionSize = 16;
constexpr size_t kLoopEdgeSize = 8;
constexpr size_t kMapPointRecordSize = 136;
constexpr size_t kObservationSize = 16;

uint64_t AlignUp(uint64_t value, uint64_t alignment) {
  return (value + alignment - 1) / alignment * alignment;
}

template <typename T>
T Load(const uint8_t* p) {
  return LoadLittleEndian<T>(p);
}
template <typename T>
void Store(uint8_t* p, T value) {
  StoreLittleEndian<T>(p, value);
}

std::string SectionText(int section) { return std::string("section ") + kSectionNames[section]; }

// ---------------------------------------------------------------------------
// Counts and sizes

MapCounts CountMap(const MapData& map) {
  MapCounts c;
  c.keyframes = map.keyframes.size();
  c.map_points = map.map_points.size();
  for (const KeyFrameRecord& kf : map.keyframes) {
    c.keypoints += kf.keypoints.size();
    c.bow_entries += kf.bow.size();
    c.feature_vector_groups += kf.feature_vector.size();
    for (const auto& group : kf.feature_vector) c.feature_vector_indices += group.second.size();
    c.connections += kf.connections.size();
    c.loop_edges += kf.loop_edges.size();
  }
  for (const MapPointRecord& p : map.map_points) c.observations += p.observations.size();
  return c;
}

// Expected size of every section but meta, from the counts. Saturates on
// overflow (a corrupt count then simply fails the size comparison).
uint64_t Times(uint64_t count, uint64_t size) {
  if (count > std::numeric_limits<uint64_t>::max() / size)
    return std::numeric_limits<uint64_t>::max();
  return count * size;
}
uint64_t Plus(uint64_t a, uint64_t b) {
  return a > std::numeric_limits<uint64_t>::max() - b ? std::numeric_limits<uint64_t>::max()
                                                      : a + b;
}

uint64_t ExpectedSectionSize(int section, const MapCounts& c) {
  switch (section) {
    case kKeyframes:
      return Times(c.keyframes, kKeyframeRecordSize);
    case kKeypoints:
      return Times(c.keypoints, kKeypointRecordSize);
    case kDescriptors:
      return Times(c.keypoints, kDescriptorSize);
    case kKfPoints:
      return Times(c.keypoints, 8);
    case kBow:
      return Times(c.bow_entries, kBowEntrySize);
    case kFeatureVectors:
      return Plus(Times(c.feature_vector_groups, kFvGroupSize),
                  Times(c.feature_vector_indices, kFvIndexSize));
    case kGraph:
      return Plus(Times(c.connections, kConnectionSize), Times(c.loop_edges, kLoopEdgeSize));
    case kMapPoints:
      return Times(c.map_points, kMapPointRecordSize);
    case kObservations:
      return Times(c.observations, kObservationSize);
  }
  return 0;
}

// ---------------------------------------------------------------------------
// Encoding

void WriteMeta(const MapData& map, const MapCounts& c, uint8_t* p) {
  Store<uint32_t>(p + 0, kMetaFixedSize);
  const MapCamera& cam = map.camera;
  const double intrinsics[9] = {cam.fx, cam.fy, cam.cx, cam.cy, cam.k1,
                                cam.k2, cam.p1, cam.p2, cam.k3};
  for (int i = 0; i < 9; ++i) Store<double>(p + 8 + 8 * i, intrinsics[i]);
  Store<int32_t>(p + 80, cam.width);
  Store<int32_t>(p + 84, cam.height);
  Store<double>(p + 88, cam.bf);
  Store<double>(p + 96, cam.th_depth);
  Store<double>(p + 104, cam.depth_map_factor);
  Store<int32_t>(p + 112, cam.orb_features);
  Store<int32_t>(p + 116, cam.orb_levels);
  Store<double>(p + 120, cam.orb_scale_factor);
  Store<int32_t>(p + 128, cam.orb_ini_th_fast);
  Store<int32_t>(p + 132, cam.orb_min_th_fast);
  const MapVocabulary& v = map.vocabulary;
  Store<uint64_t>(p + 136, v.content_hash);
  Store<int32_t>(p + 144, v.k);
  Store<int32_t>(p + 148, v.levels);
  Store<int32_t>(p + 152, v.weighting);
  Store<int32_t>(p + 156, v.scoring);
  Store<uint64_t>(p + 160, v.num_words);
  Store<int32_t>(p + 168, map.bow_levels_up);
  Store<uint64_t>(p + 176, map.next_keyframe_id);
  Store<uint64_t>(p + 184, map.next_map_point_id);
  const uint64_t counts[9] = {c.keyframes,
                              c.map_points,
                              c.keypoints,
                              c.bow_entries,
                              c.feature_vector_groups,
                              c.feature_vector_indices,
                              c.connections,
                              c.loop_edges,
                              c.observations};
  for (int i = 0; i < 9; ++i) Store<uint64_t>(p + 192 + 8 * i, counts[i]);
  Store<uint64_t>(p + 264, v.name.size());
  Store<uint64_t>(p + 272, map.metadata.size());
  if (!v.name.empty()) std::memcpy(p + kMetaFixedSize, v.name.data(), v.name.size());
  if (!map.metadata.empty()) {
    std::memcpy(p + kMetaFixedSize + v.name.size(), map.metadata.data(), map.metadata.size());
  }
}

void WriteKeypoint(const MapKeypoint& k, uint8_t* p) {
  Store<float>(p + 0, k.pixel_x);
  Store<float>(p + 4, k.pixel_y);
  Store<float>(p + 8, k.undistorted_x);
  Store<float>(p + 12, k.undistorted_y);
  Store<float>(p + 16, k.angle_deg);
  Store<float>(p + 20, k.response);
  Store<float>(p + 24, k.depth);
  Store<float>(p + 28, k.u_right);
  p[32] = k.octave;
}

void WritePose(const MapPose& T, uint8_t* p) {
  const double v[7] = {T.qw, T.qx, T.qy, T.qz, T.tx, T.ty, T.tz};
  for (int i = 0; i < 7; ++i) Store<double>(p + 8 * i, v[i]);
}

// ---------------------------------------------------------------------------
// Header and section table

struct ParsedHeader {
  MapFileInfo info;
  std::span<const uint8_t> payload;
  uint64_t payload_checksum = 0;
};

std::string SanitizedName(const uint8_t* p) {
  std::string name;
  for (size_t i = 0; i < kSectionNameSize && p[i] != 0; ++i) {
    const char c = static_cast<char>(p[i]);
    name += (c >= 0x20 && c < 0x7f) ? c : '?';
  }
  return name;
}

ParsedHeader ParseHeader(std::span<const uint8_t> file, const std::string& source) {
  if (file.size() >= 8 && !HasMagic(file, kMapFormat)) {
    throw DataError(source + ": not an rrslam map (bad magic)");
  }
  if (file.size() < kBaseHeaderSize) {
    throw DataError(source + ": truncated: " + std::to_string(file.size()) +
                    " bytes, shorter than a map header");
  }
  const uint16_t major = Load<uint16_t>(file.data() + 8);
  if (major != kMapFormat.major) {
    throw DataError(source + ": format major version " + std::to_string(major) +
                    ", this build reads " + std::to_string(kMapFormat.major));
  }
  const BinaryHeaderView view = ParseBinaryHeader(file, kMapFormat, source);
  ParsedHeader h;
  h.info.major = view.major;
  h.info.minor = view.minor;
  h.info.file_size = file.size();
  h.payload = view.payload;
  h.payload_checksum = view.payload_checksum;
  if (view.fields.size() < kTableStart) {
    throw DataError(source + ": corrupt header (no section table)");
  }
  const uint32_t count = Load<uint32_t>(view.fields.data());
  if (count > (view.fields.size() - kTableStart) / kSectionEntrySize) {
    throw DataError(source + ": corrupt header (" + std::to_string(count) +
                    " sections do not fit in the header)");
  }
  h.info.sections.resize(count);
  for (uint32_t i = 0; i < count; ++i) {
    const uint8_t* e = view.fields.data() + kTableStart + kSectionEntrySize * i;
    MapSectionInfo& s = h.info.sections[i];
    s.name = SanitizedName(e);
    s.offset = Load<uint64_t>(e + 16);
    s.size = Load<uint64_t>(e + 24);
    s.checksum = Load<uint64_t>(e + 32);
    if (s.offset > h.payload.size() || s.size > h.payload.size() - s.offset) {
      throw DataError(source + ": section " + s.name + ": bytes [" + std::to_string(s.offset) +
                      ", +" + std::to_string(s.size) + ") lie outside the " +
                      std::to_string(h.payload.size()) + "-byte payload (truncated or corrupt)");
    }
  }
  return h;
}

// The known sections' bytes, by Section.
using Sections = std::array<std::span<const uint8_t>, kNumSections>;

// Finds a known section in the table (unknown ones are ignored: a newer
// minor version may add sections) and checks its checksum.
std::span<const uint8_t> CheckedSection(const ParsedHeader& h, int section,
                                        const std::string& source) {
  const MapSectionInfo* found = nullptr;
  for (const MapSectionInfo& s : h.info.sections) {
    if (s.name != kSectionNames[section]) continue;
    if (found != nullptr) throw DataError(source + ": " + SectionText(section) + " listed twice");
    found = &s;
  }
  if (found == nullptr) throw DataError(source + ": " + SectionText(section) + " is missing");
  const std::span<const uint8_t> bytes = h.payload.subspan(found->offset, found->size);
  if (Checksum64(bytes) != found->checksum) {
    throw DataError(source + ": " + SectionText(section) + ": checksum mismatch (file corrupt)");
  }
  return bytes;
}

// The known sections, each checked against its checksum, then the whole
// payload against its own (which catches corruption between sections and in
// sections this version does not know).
Sections CheckedSections(const ParsedHeader& h, const std::string& source) {
  Sections s;
  for (int i = 0; i < kNumSections; ++i) s[i] = CheckedSection(h, i, source);
  if (Checksum64(h.payload) != h.payload_checksum) {
    throw DataError(source +
                    ": payload checksum mismatch outside the known sections (file corrupt)");
  }
  return s;
}

MapData ParseMeta(std::span<const uint8_t> m, const std::string& source, MapCounts* counts) {
  const std::string where = source + ": " + SectionText(kMeta);
  if (m.size() < kMetaFixedSize) {
    throw DataError(where + ": truncated (" + std::to_string(m.size()) + " bytes, at least " +
                    std::to_string(kMetaFixedSize) + " expected)");
  }
  const uint8_t* p = m.data();
  const uint32_t fixed_size = Load<uint32_t>(p);
  if (fixed_size < kMetaFixedSize || fixed_size > m.size()) {
    throw DataError(where + ": corrupt (fixed part of " + std::to_string(fixed_size) + " bytes)");
  }
  MapData map;
  MapCamera& cam = map.camera;
  double* intrinsics[9] = {&cam.fx, &cam.fy, &cam.cx, &cam.cy, &cam.k1,
                           &cam.k2, &cam.p1, &cam.p2, &cam.k3};
  for (int i = 0; i < 9; ++i) *intrinsics[i] = Load<double>(p + 8 + 8 * i);
  cam.width = Load<int32_t>(p + 80);
  cam.height = Load<int32_t>(p + 84);
  cam.bf = Load<double>(p + 88);
  cam.th_depth = Load<double>(p + 96);
  cam.depth_map_factor = Load<double>(p + 104);
  cam.orb_features = Load<int32_t>(p + 112);
  cam.orb_levels = Load<int32_t>(p + 116);
  cam.orb_scale_factor = Load<double>(p + 120);
  cam.orb_ini_th_fast = Load<int32_t>(p + 128);
  cam.orb_min_th_fast = Load<int32_t>(p + 132);
  MapVocabulary& v = map.vocabulary;
  v.content_hash = Load<uint64_t>(p + 136);
  v.k = Load<int32_t>(p + 144);
  v.levels = Load<int32_t>(p + 148);
  v.weighting = Load<int32_t>(p + 152);
  v.scoring = Load<int32_t>(p + 156);
  v.num_words = Load<uint64_t>(p + 160);
  map.bow_levels_up = Load<int32_t>(p + 168);
  map.next_keyframe_id = Load<uint64_t>(p + 176);
  map.next_map_point_id = Load<uint64_t>(p + 184);
  MapCounts c;
  uint64_t* fields[9] = {&c.keyframes,
                         &c.map_points,
                         &c.keypoints,
                         &c.bow_entries,
                         &c.feature_vector_groups,
                         &c.feature_vector_indices,
                         &c.connections,
                         &c.loop_edges,
                         &c.observations};
  for (int i = 0; i < 9; ++i) *fields[i] = Load<uint64_t>(p + 192 + 8 * i);
  const uint64_t name_size = Load<uint64_t>(p + 264);
  const uint64_t metadata_size = Load<uint64_t>(p + 272);
  const uint64_t room = m.size() - fixed_size;
  if (name_size > room || metadata_size > room - name_size) {
    throw DataError(where + ": strings of " + std::to_string(name_size) + " + " +
                    std::to_string(metadata_size) + " bytes exceed the section (" +
                    std::to_string(room) + " bytes left)");
  }
  v.name.assign(reinterpret_cast<const char*>(p + fixed_size), name_size);
  map.metadata.assign(reinterpret_cast<const char*>(p + fixed_size + name_size), metadata_size);
  if (counts != nullptr) *counts = c;
  return map;
}

// Throws unless `total` (summed from per-record counts) equals the meta count.
void CheckTotal(uint64_t total, uint64_t expected, const char* what, const char* section,
                const std::string& source) {
  if (total != expected) {
    throw DataError(source + ": section " + section + ": records list " + std::to_string(total) +
                    " " + what + " in total, section meta says " + std::to_string(expected));
  }
}

// Positions in the concatenated arrays of keyframe entries (counts of
// entries, not bytes).
struct KeyframeCursor {
  uint64_t keypoint = 0, bow = 0, group = 0, index = 0, connection = 0, loop = 0;
};

// Parses the keyframe of record `r`, whose entries start at `*cursor`, and
// moves `*cursor` past them.
void ParseKeyframe(const Sections& s, const MapCounts& c, const uint8_t* r, KeyframeCursor* cursor,
                   KeyFrameRecord* out) {
  KeyframeCursor& at = *cursor;
  KeyFrameRecord& kf = *out;
  kf.id = Load<uint64_t>(r + 0);
  kf.frame_id = Load<uint64_t>(r + 8);
  kf.timestamp = Load<double>(r + 16);
  MapPose& T = kf.T_cam_world;
  T.qw = Load<double>(r + 24);
  T.qx = Load<double>(r + 32);
  T.qy = Load<double>(r + 40);
  T.qz = Load<double>(r + 48);
  T.tx = Load<double>(r + 56);
  T.ty = Load<double>(r + 64);
  T.tz = Load<double>(r + 72);
  kf.parent = Load<uint64_t>(r + 80);
  const uint32_t n = Load<uint32_t>(r + 88);
  const uint32_t n_bow = Load<uint32_t>(r + 92);
  const uint32_t n_groups = Load<uint32_t>(r + 96);
  const uint32_t n_connections = Load<uint32_t>(r + 100);
  const uint32_t n_loops = Load<uint32_t>(r + 104);

  const uint8_t* keypoints = s[kKeypoints].data() + kKeypointRecordSize * at.keypoint;
  kf.keypoints.resize(n);
  for (uint32_t k = 0; k < n; ++k) {
    MapKeypoint& kp = kf.keypoints[k];
    const uint8_t* q = keypoints + kKeypointRecordSize * k;
    kp.pixel_x = Load<float>(q + 0);
    kp.pixel_y = Load<float>(q + 4);
    kp.undistorted_x = Load<float>(q + 8);
    kp.undistorted_y = Load<float>(q + 12);
    kp.angle_deg = Load<float>(q + 16);
    kp.response = Load<float>(q + 20);
    kp.depth = Load<float>(q + 24);
    kp.u_right = Load<float>(q + 28);
    kp.octave = q[32];
  }
  kf.descriptors.resize(n);
  if (n > 0) {
    std::memcpy(kf.descriptors.data(), s[kDescriptors].data() + kDescriptorSize * at.keypoint,
                kDescriptorSize * n);
  }
  kf.map_point_ids.resize(n);
  if (n > 0) {
    std::memcpy(kf.map_point_ids.data(), s[kKfPoints].data() + 8 * at.keypoint, 8 * size_t{n});
  }

  const uint8_t* bow = s[kBow].data() + kBowEntrySize * at.bow;
  kf.bow.resize(n_bow);
  for (uint32_t k = 0; k < n_bow; ++k) {
    kf.bow[k] = {Load<uint32_t>(bow + kBowEntrySize * k),
                 Load<double>(bow + kBowEntrySize * k + 8)};
  }

  const uint8_t* groups = s[kFeatureVectors].data() + kFvGroupSize * at.group;
  const uint8_t* indices =
      s[kFeatureVectors].data() + kFvGroupSize * c.feature_vector_groups + kFvIndexSize * at.index;
  kf.feature_vector.resize(n_groups);
  for (uint32_t g = 0; g < n_groups; ++g) {
    auto& [node, list] = kf.feature_vector[g];
    node = Load<uint32_t>(groups + kFvGroupSize * g);
    const uint32_t count = Load<uint32_t>(groups + kFvGroupSize * g + 4);
    list.resize(count);
    if (count > 0) std::memcpy(list.data(), indices, kFvIndexSize * count);
    indices += kFvIndexSize * count;
    at.index += count;
  }

  const uint8_t* connections = s[kGraph].data() + kConnectionSize * at.connection;
  kf.connections.resize(n_connections);
  for (uint32_t k = 0; k < n_connections; ++k) {
    kf.connections[k] = {Load<uint64_t>(connections + kConnectionSize * k),
                         Load<int32_t>(connections + kConnectionSize * k + 8)};
  }
  const uint8_t* loops =
      s[kGraph].data() + kConnectionSize * c.connections + kLoopEdgeSize * at.loop;
  kf.loop_edges.resize(n_loops);
  if (n_loops > 0) std::memcpy(kf.loop_edges.data(), loops, kLoopEdgeSize * n_loops);

  at.keypoint += n;
  at.bow += n_bow;
  at.group += n_groups;
  at.connection += n_connections;
  at.loop += n_loops;
}

// Parses the map point of record `r`, whose observations start at
// `observations`; returns the end of its observations.
const uint8_t* ParseMapPoint(const uint8_t* r, const uint8_t* observations, MapPointRecord* out) {
  MapPointRecord& mp = *out;
  mp.id = Load<uint64_t>(r + 0);
  for (int k = 0; k < 3; ++k) {
    mp.position[k] = Load<double>(r + 8 + 8 * k);
    mp.normal[k] = Load<double>(r + 32 + 8 * k);
  }
  mp.min_distance = Load<double>(r + 56);
  mp.max_distance = Load<double>(r + 64);
  std::memcpy(mp.descriptor.bytes, r + 72, kDescriptorSize);
  mp.visible = Load<int32_t>(r + 104);
  mp.found = Load<int32_t>(r + 108);
  mp.reference_keyframe = Load<uint64_t>(r + 112);
  mp.first_keyframe = Load<uint64_t>(r + 120);
  const uint32_t n = Load<uint32_t>(r + 128);
  mp.observations.resize(n);
  for (uint32_t k = 0; k < n; ++k) {
    mp.observations[k] = {Load<uint64_t>(observations + kObservationSize * k),
                          Load<uint32_t>(observations + kObservationSize * k + 8)};
  }
  return observations + kObservationSize * n;
}

MapData ParseAll(std::span<const uint8_t> file, const std::string& source, MapFileInfo* info) {
  const ParsedHeader h = ParseHeader(file, source);
  const Sections s = CheckedSections(h, source);
  MapCounts c;
  MapData map = ParseMeta(s[kMeta], source, &c);
  // Every count is checked against the size of its section before anything is
  // allocated: a corrupt count cannot cause a huge allocation.
  for (int i = kKeyframes; i < kNumSections; ++i) {
    const uint64_t expected = ExpectedSectionSize(i, c);
    if (s[i].size() != expected) {
      throw DataError(source + ": " + SectionText(i) + ": " + std::to_string(s[i].size()) +
                      " bytes, but the counts in section meta need " +
                      (expected == std::numeric_limits<uint64_t>::max()
                           ? std::string("more than 2^64")
                           : std::to_string(expected)) +
                      " (truncated or corrupt)");
    }
  }

  // Per-keyframe counts, summed (in 64 bits: each is 32-bit) and compared with
  // the totals before any per-keyframe array is filled.
  const uint8_t* kf_bytes = s[kKeyframes].data();
  KeyframeCursor sum;
  for (uint64_t i = 0; i < c.keyframes; ++i) {
    const uint8_t* r = kf_bytes + kKeyframeRecordSize * i;
    sum.keypoint += Load<uint32_t>(r + 88);
    sum.bow += Load<uint32_t>(r + 92);
    sum.group += Load<uint32_t>(r + 96);
    sum.connection += Load<uint32_t>(r + 100);
    sum.loop += Load<uint32_t>(r + 104);
  }
  CheckTotal(sum.keypoint, c.keypoints, "keypoints", "keyframes", source);
  CheckTotal(sum.bow, c.bow_entries, "bow entries", "keyframes", source);
  CheckTotal(sum.group, c.feature_vector_groups, "feature vector groups", "keyframes", source);
  CheckTotal(sum.connection, c.connections, "connections", "keyframes", source);
  CheckTotal(sum.loop, c.loop_edges, "loop edges", "keyframes", source);
  const uint8_t* groups = s[kFeatureVectors].data();
  for (uint64_t g = 0; g < c.feature_vector_groups; ++g) {
    sum.index += Load<uint32_t>(groups + kFvGroupSize * g + 4);
  }
  CheckTotal(sum.index, c.feature_vector_indices, "feature vector indices", "feature_vectors",
             source);
  const uint8_t* mp_bytes = s[kMapPoints].data();
  uint64_t sum_observations = 0;
  for (uint64_t i = 0; i < c.map_points; ++i) {
    sum_observations += Load<uint32_t>(mp_bytes + kMapPointRecordSize * i + 128);
  }
  CheckTotal(sum_observations, c.observations, "observations", "map_points", source);

  // Records. Every read below stays within its section by the checks above.
  map.keyframes.resize(c.keyframes);
  KeyframeCursor at;
  for (uint64_t i = 0; i < c.keyframes; ++i) {
    ParseKeyframe(s, c, kf_bytes + kKeyframeRecordSize * i, &at, &map.keyframes[i]);
  }
  const uint8_t* observations = s[kObservations].data();
  map.map_points.resize(c.map_points);
  for (uint64_t i = 0; i < c.map_points; ++i) {
    observations =
        ParseMapPoint(mp_bytes + kMapPointRecordSize * i, observations, &map.map_points[i]);
  }

  ValidateMapData(map, source);
  if (info != nullptr) *info = h.info;
  return map;
}

}  // namespace

// ---------------------------------------------------------------------------
// Public functions

std::vector<uint8_t> EncodeMap(const MapData& map) {
  const MapCounts c = CountMap(map);
  std::array<uint64_t, kNumSections> size{}, offset{};
  size[kMeta] = kMetaFixedSize + map.vocabulary.name.size() + map.metadata.size();
  for (int i = kKeyframes; i < kNumSections; ++i) size[i] = ExpectedSectionSize(i, c);
  uint64_t payload_size = 0;
  for (int i = 0; i < kNumSections; ++i) {
    offset[i] = AlignUp(payload_size, SectionAlignment(i));
    payload_size = offset[i] + size[i];
  }
  payload_size = AlignUp(payload_size, 8);

  std::vector<uint8_t> fields(kTableStart + kSectionEntrySize * kNumSections, 0);
  Store<uint32_t>(fields.data(), kNumSections);
  const size_t header_size = kBaseHeaderSize + fields.size();  // A multiple of 8.
  // One zeroed buffer for the whole file: padding and reserved fields are 0,
  // so the same map always gives the same bytes.
  std::vector<uint8_t> file(header_size + payload_size, 0);
  uint8_t* payload = file.data() + header_size;

  WriteMeta(map, c, payload + offset[kMeta]);
  uint8_t* kf_out = payload + offset[kKeyframes];
  uint8_t* kp_out = payload + offset[kKeypoints];
  uint8_t* desc_out = payload + offset[kDescriptors];
  uint8_t* ids_out = payload + offset[kKfPoints];
  uint8_t* bow_out = payload + offset[kBow];
  uint8_t* group_out = payload + offset[kFeatureVectors];
  uint8_t* index_out = group_out + kFvGroupSize * c.feature_vector_groups;
  uint8_t* conn_out = payload + offset[kGraph];
  uint8_t* loop_out = conn_out + kConnectionSize * c.connections;
  for (const KeyFrameRecord& kf : map.keyframes) {
    const size_t n = kf.keypoints.size();
    if (kf.descriptors.size() != n || kf.map_point_ids.size() != n) {
      throw std::invalid_argument("EncodeMap: keyframe " + std::to_string(kf.id) +
                                  ": descriptors / map_point_ids not parallel to keypoints");
    }
    Store<uint64_t>(kf_out + 0, kf.id);
    Store<uint64_t>(kf_out + 8, kf.frame_id);
    Store<double>(kf_out + 16, kf.timestamp);
    WritePose(kf.T_cam_world, kf_out + 24);
    Store<uint64_t>(kf_out + 80, kf.parent);
    Store<uint32_t>(kf_out + 88, static_cast<uint32_t>(n));
    Store<uint32_t>(kf_out + 92, static_cast<uint32_t>(kf.bow.size()));
    Store<uint32_t>(kf_out + 96, static_cast<uint32_t>(kf.feature_vector.size()));
    Store<uint32_t>(kf_out + 100, static_cast<uint32_t>(kf.connections.size()));
    Store<uint32_t>(kf_out + 104, static_cast<uint32_t>(kf.loop_edges.size()));
    kf_out += kKeyframeRecordSize;
    for (const MapKeypoint& k : kf.keypoints) {
      WriteKeypoint(k, kp_out);
      kp_out += kKeypointRecordSize;
    }
    if (n > 0) {
      std::memcpy(desc_out, kf.descriptors.data(), kDescriptorSize * n);
      std::memcpy(ids_out, kf.map_point_ids.data(), 8 * n);
    }
    desc_out += kDescriptorSize * n;
    ids_out += 8 * n;
    for (const auto& [word, value] : kf.bow) {
      Store<uint32_t>(bow_out, word);
      Store<double>(bow_out + 8, value);
      bow_out += kBowEntrySize;
    }
    for (const auto& [node, list] : kf.feature_vector) {
      Store<uint32_t>(group_out, node);
      Store<uint32_t>(group_out + 4, static_cast<uint32_t>(list.size()));
      group_out += kFvGroupSize;
      if (!list.empty()) std::memcpy(index_out, list.data(), kFvIndexSize * list.size());
      index_out += kFvIndexSize * list.size();
    }
    for (const auto& [id, weight] : kf.connections) {
      Store<uint64_t>(conn_out, id);
      Store<int32_t>(conn_out + 8, weight);
      conn_out += kConnectionSize;
    }
    if (!kf.loop_edges.empty()) {
      std::memcpy(loop_out, kf.loop_edges.data(), kLoopEdgeSize * kf.loop_edges.size());
    }
    loop_out += kLoopEdgeSize * kf.loop_edges.size();
  }
  uint8_t* mp_out = payload + offset[kMapPoints];
  uint8_t* obs_out = payload + offset[kObservations];
  for (const MapPointRecord& mp : map.map_points) {
    Store<uint64_t>(mp_out + 0, mp.id);
    for (int k = 0; k < 3; ++k) {
      Store<double>(mp_out + 8 + 8 * k, mp.position[k]);
      Store<double>(mp_out + 32 + 8 * k, mp.normal[k]);
    }
    Store<double>(mp_out + 56, mp.min_distance);
    Store<double>(mp_out + 64, mp.max_distance);
    std::memcpy(mp_out + 72, mp.descriptor.bytes, kDescriptorSize);
    Store<int32_t>(mp_out + 104, mp.visible);
    Store<int32_t>(mp_out + 108, mp.found);
    Store<uint64_t>(mp_out + 112, mp.reference_keyframe);
    Store<uint64_t>(mp_out + 120, mp.first_keyframe);
    Store<uint32_t>(mp_out + 128, static_cast<uint32_t>(mp.observations.size()));
    mp_out += kMapPointRecordSize;
    for (const auto& [kf, index] : mp.observations) {
      Store<uint64_t>(obs_out, kf);
      Store<uint32_t>(obs_out + 8, index);
      obs_out += kObservationSize;
    }
  }

  for (int i = 0; i < kNumSections; ++i) {
    uint8_t* e = fields.data() + kTableStart + kSectionEntrySize * i;
    std::memcpy(e, kSectionNames[i], std::strlen(kSectionNames[i]));
    Store<uint64_t>(e + 16, offset[i]);
    Store<uint64_t>(e + 24, size[i]);
    Store<uint64_t>(e + 32, Checksum64({payload + offset[i], size[i]}));
  }
  const std::vector<uint8_t> header =
      BuildBinaryHeader(kMapFormat, fields, {payload, static_cast<size_t>(payload_size)});
  if (header.size() != header_size) throw std::logic_error("EncodeMap: header size");
  std::memcpy(file.data(), header.data(), header_size);
  return file;
}

void WriteMapFile(const std::filesystem::path& path, const MapData& map) {
  const std::vector<uint8_t> bytes = EncodeMap(map);
  AtomicOutput out(path);
  std::FILE* f = std::fopen(out.temp_path().c_str(), "wb");
  if (f == nullptr)
    throw CantCreateError(path.string() + ": cannot create " + out.temp_path().string());
  const bool ok = std::fwrite(bytes.data(), 1, bytes.size(), f) == bytes.size();
  if (std::fclose(f) != 0 || !ok) throw CantCreateError(path.string() + ": write failed");
  out.Commit();
}

MapFileInfo ReadMapFileInfo(std::span<const uint8_t> file, const std::string& source) {
  return ParseHeader(file, source).info;
}

MapData ParseMapMeta(std::span<const uint8_t> file, const std::string& source, MapCounts* counts) {
  const ParsedHeader h = ParseHeader(file, source);
  return ParseMeta(CheckedSection(h, kMeta, source), source, counts);
}

MapData ParseMap(std::span<const uint8_t> file, const std::string& source, MapFileInfo* info) {
  return ParseAll(file, source, info);
}

MapData ReadMapFile(const std::filesystem::path& path, MapFileInfo* info) {
  RequireFile(path, "map file");
  {
    // The header first, from a mapping that reads only the pages it touches:
    // a file longer or shorter than its header says (padded to gigabytes) is
    // refused before the pre-faulting mapping below would read all of it.
    const MappedFile probe(path);
    ReadMapFileInfo(probe.bytes(), path.string());
  }
  const MappedFile file(path, /*populate=*/true);
  return ParseMap(file.bytes(), path.string(), info);
}

MapData ReadMapFileReservingHeap(const std::filesystem::path& path, double heap_factor,
                                 MapFileInfo* info) {
  std::error_code size_error;
  const uintmax_t file_bytes = std::filesystem::file_size(path, size_error);
  if (!size_error) ReserveHeap(static_cast<size_t>(heap_factor * static_cast<double>(file_bytes)));
  return ReadMapFile(path, info);
}

// ---------------------------------------------------------------------------
// Validation

namespace {

std::string KfText(uint64_t id) { return "keyframe " + std::to_string(id); }
std::string MpText(uint64_t id) { return "map point " + std::to_string(id); }
std::string IdText(uint64_t id) { return id == kNoId ? std::string("none") : std::to_string(id); }

// Id -> index lookups for validation: an open-addressing hash table (load
// <= 1/2, Fibonacci hashing), one or two probes per lookup instead of a
// binary search's ~14 mispredicted branches; ids are never kNoId (checked
// before insertion), which marks empty slots.
class IdIndex {
 public:
  explicit IdIndex(const std::vector<uint64_t>& ids) {
    int bits = 1;
    while ((size_t{1} << bits) < 2 * ids.size()) ++bits;
    shift_ = 64 - bits;
    mask_ = (size_t{1} << bits) - 1;
    slots_.assign(mask_ + 1, {kNoId, 0});
    for (size_t i = 0; i < ids.size(); ++i) {
      size_t h = Hash(ids[i]);
      while (slots_[h].first != kNoId) h = (h + 1) & mask_;
      slots_[h] = {ids[i], i};
    }
  }
  // Index of `id`, or -1.
  int64_t Find(uint64_t id) const {
    if (id == kNoId) return -1;
    for (size_t h = Hash(id);; h = (h + 1) & mask_) {
      if (slots_[h].first == id) return static_cast<int64_t>(slots_[h].second);
      if (slots_[h].first == kNoId) return -1;
    }
  }

 private:
  size_t Hash(uint64_t id) const { return (id * 0x9E3779B97F4A7C15ull) >> shift_; }
  int shift_ = 63;
  size_t mask_ = 1;
  std::vector<std::pair<uint64_t, uint64_t>> slots_;
};

bool Finite(double v) { return std::isfinite(v); }

}  // namespace

void CheckMapNextIds(const MapData& map, const std::string& source) {
  const auto check = [&](const char* field, uint64_t next, uint64_t count, const char* what) {
    if (next <= MaxNextMapId(count)) return;
    throw DataError(source + ": section meta: " + field + " " + std::to_string(next) +
                    " is above " + std::to_string(MaxNextMapId(count)) + ", the bound for " +
                    std::to_string(count) + " " + what +
                    " (2^24 + 64 each; loading allocates memory per id)");
  };
  check("next_keyframe_id", map.next_keyframe_id, map.keyframes.size(), "keyframes");
  check("next_map_point_id", map.next_map_point_id, map.map_points.size(), "map points");
}

namespace {

// ValidateMapData's checks, in the order they run; each throws DataError
// "<source>: <what>" on the first violation. Ids first (sorted lists, which
// later checks search), then each keyframe, the tree, each map point.
class MapValidator {
 public:
  MapValidator(const MapData& map, const std::string& source) : map_(map), source_(source) {}

  void Run() {
    CheckMapNextIds(map_, source_);
    CheckKeyFrameIds();
    CheckMapPointIds();
    kf_index_ = IdIndex(kf_ids_);
    mp_index_ = IdIndex(mp_ids_);
    for (const KeyFrameRecord& kf : map_.keyframes) {
      CheckKeyFrameContent(kf);
      CheckKeyFrameWords(kf);
      CheckKeyFrameEdges(kf);
    }
    if (!map_.keyframes.empty() && roots_ == 0)
      Fail("spanning tree has no root (every keyframe has a parent)");
    CheckParentChains();
    CheckMapPoints();
    CheckEveryKeypointListed();
  }

 private:
  [[noreturn]] void Fail(const std::string& what) const { throw DataError(source_ + ": " + what); }
  void CheckKeyFrameIds();
  void CheckMapPointIds();
  void CheckKeyFrameContent(const KeyFrameRecord& kf);
  void CheckKeyFrameWords(const KeyFrameRecord& kf) const;
  void CheckKeyFrameEdges(const KeyFrameRecord& kf);
  void CheckParentChains() const;
  void CheckMapPoints();
  void CheckEveryKeypointListed() const;

  const MapData& map_;
  const std::string& source_;
  // Ids: unique, sorted, below the next ids.
  std::vector<uint64_t> kf_ids_, mp_ids_;
  IdIndex kf_index_{{}}, mp_index_{{}};
  size_t roots_ = 0;
  uint64_t root_ = kNoId;
  uint64_t referenced_ = 0;    // Keypoints with a map point.
  uint64_t observations_ = 0;  // Observations listed by the map points.
};

// Keyframe ids, and each keyframe's sorted lists (the symmetry checks search them).
void MapValidator::CheckKeyFrameIds() {
  kf_ids_.resize(map_.keyframes.size());
  for (size_t i = 0; i < map_.keyframes.size(); ++i) {
    const uint64_t id = map_.keyframes[i].id;
    if (id == kNoId) {
      Fail("keyframe at index " + std::to_string(i) + ": id is the reserved 'none' id");
    }
    if (i > 0 && id <= kf_ids_[i - 1]) {
      Fail("keyframe ids not sorted and unique: " + KfText(id) + " follows " +
           KfText(kf_ids_[i - 1]));
    }
    if (id >= map_.next_keyframe_id) {
      Fail(KfText(id) + ": id not below next_keyframe_id " + std::to_string(map_.next_keyframe_id));
    }
    kf_ids_[i] = id;
    // Sorted lists first: the symmetry checks below search them.
    const KeyFrameRecord& kf = map_.keyframes[i];
    for (size_t k = 1; k < kf.connections.size(); ++k) {
      if (kf.connections[k].first <= kf.connections[k - 1].first) {
        Fail(KfText(id) + ": connections not sorted by id and unique (" +
             KfText(kf.connections[k].first) + " follows " + KfText(kf.connections[k - 1].first) +
             ")");
      }
    }
    for (size_t k = 1; k < kf.loop_edges.size(); ++k) {
      if (kf.loop_edges[k] <= kf.loop_edges[k - 1]) {
        Fail(KfText(id) + ": loop edges not sorted by id and unique (" + KfText(kf.loop_edges[k]) +
             " follows " + KfText(kf.loop_edges[k - 1]) + ")");
      }
    }
  }
}

// Map point ids, and each point's observations sorted (the keyframe checks search them).
void MapValidator::CheckMapPointIds() {
  mp_ids_.resize(map_.map_points.size());
  for (size_t i = 0; i < map_.map_points.size(); ++i) {
    const uint64_t id = map_.map_points[i].id;
    if (id == kNoId)
      Fail("map point at index " + std::to_string(i) + ": id is the reserved 'none' id");
    if (i > 0 && id <= mp_ids_[i - 1]) {
      Fail("map point ids not sorted and unique: " + MpText(id) + " follows " +
           MpText(mp_ids_[i - 1]));
    }
    if (id >= map_.next_map_point_id) {
      Fail(MpText(id) + ": id not below next_map_point_id " +
           std::to_string(map_.next_map_point_id));
    }
    mp_ids_[i] = id;
    // Sorted observations first: the keyframe checks below search them.
    const auto& obs = map_.map_points[i].observations;
    for (size_t k = 1; k < obs.size(); ++k) {
      if (obs[k].first <= obs[k - 1].first) {
        Fail(MpText(id) + ": observations not sorted by keyframe id and unique (" +
             KfText(obs[k].first) + " follows " + KfText(obs[k - 1].first) + ")");
      }
    }
  }
}

// Sizes, a finite unit pose, finite keypoints within the pyramid, map points in the map.
void MapValidator::CheckKeyFrameContent(const KeyFrameRecord& kf) {
  const int32_t orb_levels = map_.camera.orb_levels;
  const std::string k = KfText(kf.id);
  const size_t n = kf.keypoints.size();
  if (kf.descriptors.size() != n || kf.map_point_ids.size() != n) {
    Fail(k + ": " + std::to_string(n) + " keypoints but " + std::to_string(kf.descriptors.size()) +
         " descriptors and " + std::to_string(kf.map_point_ids.size()) + " map point ids");
  }
  const MapPose& T = kf.T_cam_world;
  if (!Finite(kf.timestamp)) Fail(k + ": timestamp is not finite");
  if (!(Finite(T.qw) && Finite(T.qx) && Finite(T.qy) && Finite(T.qz) && Finite(T.tx) &&
        Finite(T.ty) && Finite(T.tz))) {
    Fail(k + ": pose T_cam_world is not finite");
  }
  const double norm = std::sqrt(T.qw * T.qw + T.qx * T.qx + T.qy * T.qy + T.qz * T.qz);
  if (std::abs(norm - 1.0) > 1e-6) {
    char text[64];
    std::snprintf(text, sizeof(text), "%.9g", norm);
    Fail(k + ": pose quaternion has norm " + text + ", not 1 (within 1e-6)");
  }
  for (size_t i = 0; i < n; ++i) {
    const MapKeypoint& p = kf.keypoints[i];
    if (!(std::isfinite(p.pixel_x) && std::isfinite(p.pixel_y) && std::isfinite(p.undistorted_x) &&
          std::isfinite(p.undistorted_y) && std::isfinite(p.angle_deg) &&
          std::isfinite(p.response) && std::isfinite(p.depth) && std::isfinite(p.u_right))) {
      Fail(k + " keypoint " + std::to_string(i) + ": a value is not finite");
    }
    if (p.octave >= orb_levels) {
      Fail(k + " keypoint " + std::to_string(i) + ": octave " + std::to_string(p.octave) +
           " not below the camera's ORB levels " + std::to_string(orb_levels));
    }
    const uint64_t mp_id = kf.map_point_ids[i];
    if (mp_id == kNoId) continue;
    if (mp_index_.Find(mp_id) < 0) {
      Fail(k + " keypoint " + std::to_string(i) + " has " + MpText(mp_id) +
           ", which is not in the map");
    }
    ++referenced_;
  }
}

// Bag of words and feature vector: sorted, within the vocabulary and the keypoints.
void MapValidator::CheckKeyFrameWords(const KeyFrameRecord& kf) const {
  const std::string k = KfText(kf.id);
  const size_t n = kf.keypoints.size();
  const uint64_t num_words = map_.vocabulary.num_words;
  for (size_t i = 0; i < kf.bow.size(); ++i) {
    const auto& [word, value] = kf.bow[i];
    if (i > 0 && word <= kf.bow[i - 1].first) {
      Fail(k + ": bag of words not sorted by word (word " + std::to_string(word) + " follows " +
           std::to_string(kf.bow[i - 1].first) + ")");
    }
    if (word >= num_words) {
      Fail(k + ": bag of words has word " + std::to_string(word) + ", not below the " +
           std::to_string(num_words) + " words of the vocabulary");
    }
    if (!Finite(value))
      Fail(k + ": bag of words value of word " + std::to_string(word) + " is not finite");
  }
  for (size_t g = 0; g < kf.feature_vector.size(); ++g) {
    const auto& [node, list] = kf.feature_vector[g];
    if (g > 0 && node <= kf.feature_vector[g - 1].first) {
      Fail(k + ": feature vector not sorted by node (node " + std::to_string(node) + " follows " +
           std::to_string(kf.feature_vector[g - 1].first) + ")");
    }
    for (size_t j = 0; j < list.size(); ++j) {
      if (list[j] >= n) {
        Fail(k + ": feature vector node " + std::to_string(node) + " has keypoint " +
             std::to_string(list[j]) + ", not below its " + std::to_string(n) + " keypoints");
      }
      if (j > 0 && list[j] <= list[j - 1]) {
        Fail(k + ": feature vector node " + std::to_string(node) +
             " keypoint indices not sorted and unique");
      }
    }
  }
}

// Covisibility and loop edges symmetric; one root; parents in the map.
void MapValidator::CheckKeyFrameEdges(const KeyFrameRecord& kf) {
  const std::string k = KfText(kf.id);
  for (size_t i = 0; i < kf.connections.size(); ++i) {
    const auto& [other, weight] = kf.connections[i];
    if (other == kf.id) Fail(k + ": connected to itself");
    const int64_t o = kf_index_.Find(other);
    if (o < 0) Fail(k + ": connected to " + KfText(other) + ", which is not in the map");
    const auto& back = map_.keyframes[o].connections;
    const auto it = std::lower_bound(
        back.begin(), back.end(), kf.id,
        [](const std::pair<uint64_t, int32_t>& c, uint64_t id) { return c.first < id; });
    if (it == back.end() || it->first != kf.id) {
      Fail("covisibility not symmetric: " + k + " lists " + KfText(other) + " (weight " +
           std::to_string(weight) + ") but " + KfText(other) + " does not list " + k);
    }
    if (it->second != weight) {
      Fail("covisibility not symmetric: " + k + " lists " + KfText(other) + " with weight " +
           std::to_string(weight) + " but " + KfText(other) + " lists " + k + " with weight " +
           std::to_string(it->second));
    }
  }
  for (size_t i = 0; i < kf.loop_edges.size(); ++i) {
    const uint64_t other = kf.loop_edges[i];
    if (other == kf.id) Fail(k + ": loop edge to itself");
    const int64_t o = kf_index_.Find(other);
    if (o < 0) Fail(k + ": loop edge to " + KfText(other) + ", which is not in the map");
    const auto& back = map_.keyframes[o].loop_edges;
    if (!std::binary_search(back.begin(), back.end(), kf.id)) {
      Fail("loop edges not symmetric: " + k + " lists " + KfText(other) + " but " + KfText(other) +
           " does not list " + k);
    }
  }
  if (kf.parent == kNoId) {
    ++roots_;
    if (roots_ > 1) {
      Fail("spanning tree has more than one root: " + KfText(root_) + " and " + k +
           " have no parent");
    }
    root_ = kf.id;
  } else if (kf.parent == kf.id) {
    Fail(k + ": its own spanning-tree parent");
  } else if (kf_index_.Find(kf.parent) < 0) {
    Fail(k + ": parent " + KfText(kf.parent) + " is not in the map");
  }
}

// Parent chains: 0 unvisited, 1 on the current chain, 2 reaches the root.
void MapValidator::CheckParentChains() const {
  std::vector<uint8_t> state(map_.keyframes.size(), 0);
  std::vector<size_t> chain;
  for (size_t start = 0; start < map_.keyframes.size(); ++start) {
    chain.clear();
    size_t i = start;
    while (state[i] == 0) {
      state[i] = 1;
      chain.push_back(i);
      const uint64_t parent = map_.keyframes[i].parent;
      if (parent == kNoId) break;
      i = static_cast<size_t>(kf_index_.Find(parent));  // Exists: checked above.
      if (state[i] == 1) {
        Fail("spanning tree has a cycle through " + KfText(map_.keyframes[i].id) +
             " (its parent chain never reaches the root " + KfText(root_) + ")");
      }
    }
    for (size_t j : chain) state[j] = 2;
  }
}

// Finite values; observations of keyframes in the map whose keypoints name
// the point back; the reference keyframe among the observers.
void MapValidator::CheckMapPoints() {
  for (const MapPointRecord& mp : map_.map_points) {
    for (int k = 0; k < 3; ++k) {
      if (!Finite(mp.position[k]) || !Finite(mp.normal[k])) {
        Fail(MpText(mp.id) + ": position or normal is not finite");
      }
    }
    if (!Finite(mp.min_distance) || !Finite(mp.max_distance)) {
      Fail(MpText(mp.id) + ": min/max distance is not finite");
    }
    bool references = false;
    for (size_t i = 0; i < mp.observations.size(); ++i) {
      const auto& [kf_id, index] = mp.observations[i];
      const int64_t o = kf_index_.Find(kf_id);
      if (o < 0) Fail(MpText(mp.id) + " lists " + KfText(kf_id) + ", which is not in the map");
      const KeyFrameRecord& kf = map_.keyframes[o];
      if (index >= kf.keypoints.size()) {
        Fail(MpText(mp.id) + " lists " + KfText(kf_id) + " keypoint " + std::to_string(index) +
             " but " + KfText(kf_id) + " has " + std::to_string(kf.keypoints.size()) +
             " keypoints");
      }
      if (kf.map_point_ids[index] != mp.id) {
        Fail(MpText(mp.id) + " lists " + KfText(kf_id) + " keypoint " + std::to_string(index) +
             " but " + KfText(kf_id) + " keypoint " + std::to_string(index) + " has map point " +
             IdText(kf.map_point_ids[index]));
      }
      references |= kf_id == mp.reference_keyframe;
    }
    if (!references) {
      Fail(MpText(mp.id) + ": reference " + KfText(mp.reference_keyframe) + " does not observe it");
    }
    observations_ += mp.observations.size();
  }
}

// Every observation (point, keyframe, keypoint) names a distinct keypoint
// that names the point back (checked above): when there are as many
// keypoints with a map point as observations, every such keypoint is listed
// by its point. This replaces a search of the point's observations per
// keypoint (random access over all points: 20+ ms on a 150-keyframe map);
// the search runs only to name the keypoint when the counts differ.
void MapValidator::CheckEveryKeypointListed() const {
  if (referenced_ != observations_) {
    for (const KeyFrameRecord& kf : map_.keyframes) {
      for (uint32_t i = 0; i < kf.map_point_ids.size(); ++i) {
        const uint64_t mp_id = kf.map_point_ids[i];
        if (mp_id == kNoId) continue;
        const auto& obs = map_.map_points[mp_index_.Find(mp_id)].observations;
        const auto it = std::lower_bound(
            obs.begin(), obs.end(), kf.id,
            [](const std::pair<uint64_t, uint32_t>& o, uint64_t id) { return o.first < id; });
        if (it == obs.end() || it->first != kf.id || it->second != i) {
          Fail(KfText(kf.id) + " keypoint " + std::to_string(i) + " has " + MpText(mp_id) +
               " but " + MpText(mp_id) + " does not list keyframe " + std::to_string(kf.id) +
               " keypoint " + std::to_string(i) +
               (it != obs.end() && it->first == kf.id
                    ? " (it lists keypoint " + std::to_string(it->second) + ")"
                    : ""));
        }
      }
    }
    Fail(std::to_string(referenced_) + " keypoints have a map point but the map points list " +
         std::to_string(observations_) + " observations");
  }
}

}  // namespace

void ValidateMapData(const MapData& map, const std::string& source) {
  MapValidator(map, source).Run();
}

}  // namespace rrslam
