#include "stages/mapstore/map_file.h"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cerrno>
#include <cmath>
#include <cstddef>
#include <cstdio>
#include <cstring>
#include <functional>
#include <future>
#include <limits>
#include <memory>
#include <stdexcept>
#include <system_error>
#include <type_traits>
#include <utility>

#include "common/atomic_file.h"
#include "common/binary_header.h"
#include "common/errors.h"
#include "common/formats.h"
#include "common/heap_reserve.h"
#include "common/path_check.h"
#include "stages/mapstore/file_sink.h"

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
constexpr size_t kDescriptorSize = 32;
constexpr size_t kFvGroupSize = 8;
constexpr size_t kFvIndexSize = 4;
constexpr size_t kConnectionSize = 16;
constexpr size_t kLoopEdgeSize = 8;
constexpr size_t kMapPointRecordSize = 136;

// The records whose size format 2.0 changed (docs/mapstore.md, "Versions");
// files of format 1.x still read.
struct RecordSizes {
  // 1.x: 36 bytes (u_right at 28, the octave at 32); 2.0: Keypoint's 32.
  size_t keypoint;
  size_t bow_entry;    // 1.x: 16 (4 bytes reserved, the value at 8); 2.0: 12 (at 4).
  size_t observation;  // 1.x: 16 (4 bytes reserved); 2.0: 12.
};
constexpr RecordSizes kRecordSizes1 = {36, 16, 16};
constexpr RecordSizes kRecordSizes2 = {32, 12, 12};
// Those of a file of format `major` (1 or 2).
const RecordSizes& RecordSizesOf(uint16_t major) {
  return major == 1 ? kRecordSizes1 : kRecordSizes2;
}

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

// The other maps' sections (since format 1.1) are named "<k>:<short name>" for
// the k-th other map: "1:kp" (16 bytes hold at most "99:graph").
constexpr std::array<const char*, kNumSections> kOtherMapSectionNames = {
    "meta", "kf", "kp", "desc", "kfp", "bow", "fv", "graph", "mp", "obs"};

// A section's name in the table: the map's own, or its k-th other map's.
std::string SectionName(size_t map, int section) {
  return map == 0 ? std::string(kSectionNames[section])
                  : std::to_string(map) + ":" + kOtherMapSectionNames[section];
}

std::string SectionText(int section, size_t map = 0) {
  return "section " + SectionName(map, section);
}

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

uint64_t ExpectedSectionSize(int section, const MapCounts& c, const RecordSizes& r) {
  switch (section) {
    case kKeyframes:
      return Times(c.keyframes, kKeyframeRecordSize);
    case kKeypoints:
      return Times(c.keypoints, r.keypoint);
    case kDescriptors:
      return Times(c.keypoints, kDescriptorSize);
    case kKfPoints:
      return Times(c.keypoints, 8);
    case kBow:
      return Times(c.bow_entries, r.bow_entry);
    case kFeatureVectors:
      return Plus(Times(c.feature_vector_groups, kFvGroupSize),
                  Times(c.feature_vector_indices, kFvIndexSize));
    case kGraph:
      return Plus(Times(c.connections, kConnectionSize), Times(c.loop_edges, kLoopEdgeSize));
    case kMapPoints:
      return Times(c.map_points, kMapPointRecordSize);
    case kObservations:
      return Times(c.observations, r.observation);
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

// A keypoint record of format 2.0 (Keypoint's layout; the padding after
// the octave zero, as `p` comes).
void WriteKeypoint(const Keypoint& k, uint8_t* p) {
  Store<float>(p + 0, k.pixel.x());
  Store<float>(p + 4, k.pixel.y());
  Store<float>(p + 8, k.undistorted.x());
  Store<float>(p + 12, k.undistorted.y());
  Store<float>(p + 16, k.angle_deg);
  p[20] = k.octave;
  Store<float>(p + 24, k.response);
  Store<float>(p + 28, k.depth);
}

void WritePose(const MapPose& T, uint8_t* p) {
  const double v[7] = {T.qw, T.qx, T.qy, T.qz, T.tx, T.ty, T.tz};
  for (int i = 0; i < 7; ++i) Store<double>(p + 8 * i, v[i]);
}

void WriteMapPoint(const MapPointRecord& mp, uint8_t* p) {
  Store<uint64_t>(p + 0, mp.id);
  for (int k = 0; k < 3; ++k) {
    Store<double>(p + 8 + 8 * k, mp.position[k]);
    Store<double>(p + 32 + 8 * k, mp.normal[k]);
  }
  Store<double>(p + 56, mp.min_distance);
  Store<double>(p + 64, mp.max_distance);
  std::memcpy(p + 72, mp.descriptor.bytes, kDescriptorSize);
  Store<int32_t>(p + 104, mp.visible);
  Store<int32_t>(p + 108, mp.found);
  Store<uint64_t>(p + 112, mp.reference_keyframe);
  Store<uint64_t>(p + 120, mp.first_keyframe);
  Store<uint32_t>(p + 128, static_cast<uint32_t>(mp.observations.size()));
}

// Where every section goes: sizes and offsets from the counts (sections in
// table order, each at its alignment), the header's size.
// Where one map's sections go in the payload.
struct MapPartLayout {
  const MapData* map = nullptr;
  MapCounts counts;
  std::array<uint64_t, kNumSections> size{}, offset{};
};

// The file's layout: the map's sections, then each of its other maps'.
struct MapLayout {
  std::vector<MapPartLayout> parts;
  uint64_t payload_size = 0;
  size_t header_size = 0;
  size_t num_sections() const { return parts.size() * kNumSections; }
};

MapLayout LayOut(const MapData& map) {
  if (map.other_maps.size() > kMaxOtherMaps) {
    throw std::invalid_argument("EncodeMap: " + std::to_string(map.other_maps.size()) +
                                " other maps; at most " + std::to_string(kMaxOtherMaps));
  }
  MapLayout l;
  std::vector<const MapData*> maps = {&map};
  for (const MapData& other : map.other_maps) maps.push_back(&other);
  for (const MapData* m : maps) {
    MapPartLayout& part = l.parts.emplace_back();
    part.map = m;
    part.counts = CountMap(*m);
    part.size[kMeta] = kMetaFixedSize + m->vocabulary.name.size() + m->metadata.size();
    for (int i = kKeyframes; i < kNumSections; ++i) {
      part.size[i] = ExpectedSectionSize(i, part.counts, kRecordSizes2);
    }
    for (int i = 0; i < kNumSections; ++i) {
      part.offset[i] = AlignUp(l.payload_size, SectionAlignment(i));
      l.payload_size = part.offset[i] + part.size[i];
    }
  }
  l.payload_size = AlignUp(l.payload_size, 8);
  l.header_size = kBaseHeaderSize + kTableStart + kSectionEntrySize * l.num_sections();
  return l;
}

// Receives the file's bytes at their offsets, a chunk at a time.
using PayloadSink = std::function<void(uint64_t offset, std::span<const uint8_t>)>;

// The payload in order, through an aligned buffer that stands for
// kChunkBytes of the file at a time (file offsets [k kChunkBytes, (k + 1)
// kChunkBytes); the bytes of the first chunk before the payload are the
// header's place, zero), handed to the sink when full: every piece but the
// last is an aligned whole that FileSink writes directly. Checksums of the
// payload and of the section being written (padding between sections is
// zero and belongs to no section).
class PayloadWriter {
 public:
  static constexpr size_t kChunkBytes = size_t{4} << 20;
  static_assert(kChunkBytes % FileSink::kAlignment == 0);

  // The payload starts at file offset `payload_offset`.
  PayloadWriter(uint64_t payload_offset, PayloadSink sink)
      : sink_(std::move(sink)),
        chunk_(FileSink::AlignedBuffer(kBufferBytes)),
        payload_offset_(payload_offset) {
    base_ = payload_offset - payload_offset % kChunkBytes;
    fill_ = hashed_ = payload_offset - base_;
    std::memset(chunk_.get(), 0, fill_);
  }

  // Zero bytes up to payload offset `offset`, then a section starts there.
  void BeginSection(uint64_t offset) {
    if (offset < written()) throw std::logic_error("EncodeMap: section offsets");
    Zeros(offset - written());
    Hash();
    section_ = StreamingChecksum64();
    section_start_ = offset;
  }
  // The section's checksum; throws unless it took `size` bytes.
  uint64_t EndSection(uint64_t size) {
    Hash();
    if (written() - section_start_ != size) throw std::logic_error("EncodeMap: section size");
    return section_.Digest();
  }
  // Space for one zeroed record of `size` (<= kRecordBytes) bytes: in the
  // slack after the chunk when it runs past it.
  uint8_t* Record(size_t size) {
    if (size > kRecordBytes) throw std::logic_error("EncodeMap: record size");
    if (fill_ >= kChunkBytes) Flush();
    uint8_t* p = chunk_.get() + fill_;
    std::memset(p, 0, size);
    fill_ += size;
    return p;
  }
  void Bytes(const void* data, size_t size) {
    const auto* p = static_cast<const uint8_t*>(data);
    while (size > 0) {
      if (fill_ >= kChunkBytes) Flush();
      const size_t n = std::min(size, kChunkBytes - fill_);
      std::memcpy(chunk_.get() + fill_, p, n);
      fill_ += n;
      p += n;
      size -= n;
    }
  }
  void Zeros(uint64_t size) {
    while (size > 0) {
      if (fill_ >= kChunkBytes) Flush();
      const size_t n = std::min<uint64_t>(size, kChunkBytes - fill_);
      std::memset(chunk_.get() + fill_, 0, n);
      fill_ += n;
      size -= n;
    }
  }
  // Pads to `payload_size`, hands over the rest; the payload's checksum.
  uint64_t Finish(uint64_t payload_size) {
    Zeros(payload_size - written());
    Hash();
    while (fill_ >= kChunkBytes) Flush();
    if (fill_ > 0) sink_(base_, {chunk_.get(), fill_});
    return payload_.Digest();
  }

 private:
  static constexpr size_t kRecordBytes = 256;
  static constexpr size_t kBufferBytes = kChunkBytes + FileSink::kAlignment;
  static_assert(kBufferBytes - kChunkBytes >= kRecordBytes, "the slack holds a record");

  // Payload bytes so far.
  uint64_t written() const { return base_ + fill_ - payload_offset_; }
  // The checksums over the bytes since the last call.
  void Hash() {
    const std::span<const uint8_t> bytes(chunk_.get() + hashed_, fill_ - hashed_);
    payload_.Update(bytes);
    section_.Update(bytes);
    hashed_ = fill_;
  }
  // The full chunk to the sink; a record that ran past it moves to the front.
  void Flush() {
    Hash();
    sink_(base_, {chunk_.get(), kChunkBytes});
    base_ += kChunkBytes;
    fill_ -= kChunkBytes;
    std::memmove(chunk_.get(), chunk_.get() + kChunkBytes, fill_);
    hashed_ = fill_;
  }

  PayloadSink sink_;
  FileSink::Buffer chunk_;
  uint64_t payload_offset_ = 0;
  uint64_t base_ = 0;  // File offset of chunk_[0].
  size_t fill_ = 0, hashed_ = 0;
  uint64_t section_start_ = 0;
  StreamingChecksum64 payload_, section_;
};

// One pass over the keyframes per section.
void EncodeKeyframeTable(const MapData& map, PayloadWriter* w) {
  for (const KeyFrameRecord& kf : map.keyframes) {
    const size_t n = kf.keypoints.size();
    if (kf.descriptors.size() != n || kf.map_point_ids.size() != n) {
      throw std::invalid_argument("EncodeMap: keyframe " + std::to_string(kf.id) +
                                  ": descriptors / map_point_ids not parallel to keypoints");
    }
    uint8_t* r = w->Record(kKeyframeRecordSize);
    Store<uint64_t>(r + 0, kf.id);
    Store<uint64_t>(r + 8, kf.frame_id);
    Store<double>(r + 16, kf.timestamp);
    WritePose(kf.T_cam_world, r + 24);
    Store<uint64_t>(r + 80, kf.parent);
    Store<uint32_t>(r + 88, static_cast<uint32_t>(n));
    Store<uint32_t>(r + 92, static_cast<uint32_t>(kf.bow.size()));
    Store<uint32_t>(r + 96, static_cast<uint32_t>(kf.feature_vector.size()));
    Store<uint32_t>(r + 100, static_cast<uint32_t>(kf.connections.size()));
    Store<uint32_t>(r + 104, static_cast<uint32_t>(kf.loop_edges.size()));
  }
}

void EncodeSection(const MapData& map, int section, PayloadWriter* w) {
  const auto each = [&](auto&& f) {
    for (const KeyFrameRecord& kf : map.keyframes) f(kf);
  };
  switch (section) {
    case kKeyframes:
      return EncodeKeyframeTable(map, w);
    case kKeypoints:
      return each([&](const KeyFrameRecord& kf) {
        for (const Keypoint& k : kf.keypoints) {
          WriteKeypoint(k, w->Record(kRecordSizes2.keypoint));
        }
      });
    case kDescriptors:
      return each([&](const KeyFrameRecord& kf) {
        w->Bytes(kf.descriptors.data(), kDescriptorSize * kf.descriptors.size());
      });
    case kKfPoints:
      return each([&](const KeyFrameRecord& kf) {
        w->Bytes(kf.map_point_ids.data(), 8 * kf.map_point_ids.size());
      });
    case kBow:
      return each([&](const KeyFrameRecord& kf) {
        for (const auto& [word, value] : kf.bow) {
          uint8_t* r = w->Record(kRecordSizes2.bow_entry);
          Store<uint32_t>(r, word);
          Store<double>(r + 4, value);
        }
      });
    case kFeatureVectors:
      each([&](const KeyFrameRecord& kf) {
        for (const auto& [node, list] : kf.feature_vector) {
          uint8_t* r = w->Record(kFvGroupSize);
          Store<uint32_t>(r, node);
          Store<uint32_t>(r + 4, static_cast<uint32_t>(list.size()));
        }
      });
      return each([&](const KeyFrameRecord& kf) {
        for (const auto& group : kf.feature_vector) {
          w->Bytes(group.second.data(), kFvIndexSize * group.second.size());
        }
      });
    case kGraph:
      each([&](const KeyFrameRecord& kf) {
        for (const auto& [id, weight] : kf.connections) {
          uint8_t* r = w->Record(kConnectionSize);
          Store<uint64_t>(r, id);
          Store<int32_t>(r + 8, weight);
        }
      });
      return each([&](const KeyFrameRecord& kf) {
        w->Bytes(kf.loop_edges.data(), kLoopEdgeSize * kf.loop_edges.size());
      });
    case kMapPoints:
      for (const MapPointRecord& mp : map.map_points)
        WriteMapPoint(mp, w->Record(kMapPointRecordSize));
      return;
    case kObservations:
      for (const MapPointRecord& mp : map.map_points) {
        for (const auto& [kf, index] : mp.observations) {
          uint8_t* r = w->Record(kRecordSizes2.observation);
          Store<uint64_t>(r, kf);
          Store<uint32_t>(r + 8, index);
        }
      }
      return;
  }
}

struct EncodedHeader {
  std::vector<uint8_t> bytes;  // The whole header, section table included.
  MapFileInfo info;
};

// Streams the payload laid out as `layout` to `sink`; the header (format
// 2.0, with or without other maps).
EncodedHeader EncodeWith(const MapLayout& layout, PayloadSink sink) {
  PayloadWriter w(layout.header_size, std::move(sink));
  EncodedHeader out;
  const FormatSpec format = kMapFormat;
  out.info.major = format.major;
  out.info.minor = format.minor;
  out.info.file_size = layout.header_size + layout.payload_size;
  for (size_t m = 0; m < layout.parts.size(); ++m) {
    const MapPartLayout& part = layout.parts[m];
    for (int i = 0; i < kNumSections; ++i) {
      w.BeginSection(part.offset[i]);
      if (i == kMeta) {
        std::vector<uint8_t> meta(part.size[kMeta], 0);
        WriteMeta(*part.map, part.counts, meta.data());
        w.Bytes(meta.data(), meta.size());
      } else {
        EncodeSection(*part.map, i, &w);
      }
      out.info.sections.push_back(
          {SectionName(m, i), part.offset[i], part.size[i], w.EndSection(part.size[i])});
    }
  }
  const uint64_t payload_checksum = w.Finish(layout.payload_size);

  const size_t count = layout.num_sections();
  std::vector<uint8_t> fields(kTableStart + kSectionEntrySize * count, 0);
  Store<uint32_t>(fields.data(), static_cast<uint32_t>(count));
  for (size_t i = 0; i < count; ++i) {
    const MapSectionInfo& section = out.info.sections[i];
    if (section.name.size() > kSectionNameSize) {
      throw std::logic_error("EncodeMap: section name " + section.name + " is too long");
    }
    uint8_t* e = fields.data() + kTableStart + kSectionEntrySize * i;
    std::memcpy(e, section.name.data(), section.name.size());
    Store<uint64_t>(e + 16, section.offset);
    Store<uint64_t>(e + 24, section.size);
    Store<uint64_t>(e + 32, section.checksum);
  }
  out.bytes = BuildBinaryHeader(format, fields, layout.payload_size, payload_checksum);
  if (out.bytes.size() != layout.header_size) throw std::logic_error("EncodeMap: header size");
  return out;
}

// ---------------------------------------------------------------------------
// Header and section table

struct ParsedHeader {
  MapFileInfo info;
  std::span<const uint8_t> payload;
  uint64_t payload_checksum = 0;
  RecordSizes sizes = kRecordSizes2;  // Of info.major.
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
  if (major != 1 && major != kMapFormat.major) {
    throw DataError(source + ": format major version " + std::to_string(major) +
                    ", this build reads 1 and " + std::to_string(kMapFormat.major));
  }
  FormatSpec spec = kMapFormat;
  spec.major = major;
  const BinaryHeaderView view = ParseBinaryHeader(file, spec, source);
  ParsedHeader h;
  h.sizes = RecordSizesOf(major);
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

// Finds a known section of the map (0) or of its k-th other map in the
// table (unknown ones are ignored: a newer minor version may add sections);
// nullptr when absent.
const MapSectionInfo* FindSection(const ParsedHeader& h, int section, const std::string& source,
                                  size_t map = 0) {
  const std::string name = SectionName(map, section);
  const MapSectionInfo* found = nullptr;
  for (const MapSectionInfo& s : h.info.sections) {
    if (s.name != name) continue;
    if (found != nullptr) {
      throw DataError(source + ": " + SectionText(section, map) + " listed twice");
    }
    found = &s;
  }
  return found;
}

// A known section's bytes; `check`: against its own checksum too.
std::span<const uint8_t> FoundSection(const ParsedHeader& h, int section, const std::string& source,
                                      size_t map = 0, bool check = false) {
  const MapSectionInfo* found = FindSection(h, section, source, map);
  if (found == nullptr) {
    throw DataError(source + ": " + SectionText(section, map) + " is missing");
  }
  const std::span<const uint8_t> bytes = h.payload.subspan(found->offset, found->size);
  if (check && Checksum64(bytes) != found->checksum) {
    throw DataError(source + ": " + SectionText(section, map) +
                    ": checksum mismatch (file corrupt)");
  }
  return bytes;
}

// A known section's bytes, checked against its checksum.
std::span<const uint8_t> CheckedSection(const ParsedHeader& h, int section,
                                        const std::string& source, size_t map = 0) {
  return FoundSection(h, section, source, map, /*check=*/true);
}

// The known sections of a map (0) or of its k-th other map (their bytes:
// the payload's checksum vouches for them, CheckPayload).
Sections FoundSections(const ParsedHeader& h, const std::string& source, size_t map = 0) {
  Sections s;
  for (int i = 0; i < kNumSections; ++i) s[i] = FoundSection(h, i, source, map);
  return s;
}

// The whole payload against its checksum: one pass over every byte.
bool PayloadIntact(const ParsedHeader& h) { return Checksum64(h.payload) == h.payload_checksum; }

// The error of a payload whose checksum failed: the known sections checked
// one by one name the corrupt one (sections of the map, then of its other
// maps, `parts` of them); when they all pass, the corruption lies between
// sections or in a section this version does not know.
[[noreturn]] void ThrowCorruptPayload(const ParsedHeader& h, size_t parts,
                                      const std::string& source) {
  for (size_t map = 0; map < parts; ++map) {
    for (int i = 0; i < kNumSections; ++i) CheckedSection(h, i, source, map);
  }
  throw DataError(source + ": payload checksum mismatch outside the known sections (file corrupt)");
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

// Per-keyframe entry counts of a keyframe record.
struct KeyframeCounts {
  uint32_t keypoints = 0, bow = 0, groups = 0, connections = 0, loops = 0;
};

KeyframeCounts CountsOf(const uint8_t* r) {
  return {Load<uint32_t>(r + 88), Load<uint32_t>(r + 92), Load<uint32_t>(r + 96),
          Load<uint32_t>(r + 100), Load<uint32_t>(r + 104)};
}

// The fixed fields of the keyframe record `r`.
void ParseKeyframeRecord(const uint8_t* r, KeyFrameRecord* out) {
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
}

// A keypoint record of format 2.0 is a Keypoint's bytes (little-endian
// host), viewed in place: the offsets WriteKeypoint writes (a Pixel2f is its
// x then its y, common/keypoint.h); the 3 bytes after the octave are padding
// (0 in the file).
static_assert(sizeof(Keypoint) == kRecordSizes2.keypoint && alignof(Keypoint) == 4);
static_assert(offsetof(Keypoint, pixel) == 0 && offsetof(Keypoint, undistorted) == 8 &&
              offsetof(Keypoint, angle_deg) == 16 && offsetof(Keypoint, octave) == 20 &&
              offsetof(Keypoint, response) == 24 && offsetof(Keypoint, depth) == 28);
static_assert(std::is_trivially_copyable_v<Keypoint>);
static_assert(sizeof(OrbDescriptor) == kDescriptorSize);

// Copies `count` entries of `size` bytes at `*p` into `out` (trivially
// copyable, the same layout) and moves `*p` past them.
template <typename T>
void CopyEntries(const uint8_t** p, uint32_t count, size_t size, std::vector<T>* out) {
  static_assert(std::is_trivially_copyable_v<T>);
  out->resize(count);
  if (count > 0) std::memcpy(out->data(), *p, size * count);
  *p += size * count;
}

// The `count` entries of sizeof(T) bytes at `*p` (T's layout) as a view of
// the mapped file that `mapping` keeps alive, or copied when there is none;
// moves `*p` past them. Sections start aligned for their records
// (SectionAlignment) and records are multiples of their alignment, so the
// entries are aligned for T; a copy is the fallback if not.
template <typename T>
RecordArray<T> EntriesAt(const uint8_t** p, uint32_t count,
                         const std::shared_ptr<const void>& mapping) {
  const uint8_t* at = *p;
  *p += sizeof(T) * count;
  if (mapping != nullptr && reinterpret_cast<uintptr_t>(at) % alignof(T) == 0) {
    return RecordArray<T>::View(reinterpret_cast<const T*>(at), count, mapping);
  }
  std::vector<T> copy;
  CopyEntries(&at, count, sizeof(T), &copy);
  return copy;
}

// Reads `count` records of `size` bytes at `*p`, each a First at byte 0 and
// a Second at byte `second_at` (bag-of-words entries, connections), and
// moves `*p` past them.
template <typename First, typename Second>
void ParsePairs(const uint8_t** p, uint32_t count, size_t size, size_t second_at,
                std::vector<std::pair<First, Second>>* out) {
  out->resize(count);
  for (auto& [first, second] : *out) {
    first = Load<First>(*p);
    second = Load<Second>(*p + second_at);
    *p += size;
  }
}

// The `count` keypoint records of format 1.x at `*p` (36 bytes: the floats
// pixel x, y, undistorted x, y, angle, response, depth, u_right, then the
// octave) copied; moves `*p` past them. u_right is dropped (it follows from
// the depth).
RecordArray<Keypoint> KeypointsOfFormat1(const uint8_t** p, uint32_t count) {
  std::vector<Keypoint> out(count);
  for (Keypoint& k : out) {
    const uint8_t* r = *p;
    k.pixel = {Load<float>(r + 0), Load<float>(r + 4)};
    k.undistorted = {Load<float>(r + 8), Load<float>(r + 12)};
    k.angle_deg = Load<float>(r + 16);
    k.response = Load<float>(r + 20);
    k.depth = Load<float>(r + 24);
    k.octave = r[32];
    *p += kRecordSizes1.keypoint;
  }
  return out;
}

// Fills one section's entries of every keyframe, in keyframe order (the
// counts were checked against the section's size before); keypoints,
// descriptors and map point ids view `mapping` when it is not null (the
// keypoints of a 1.x file, of another layout, are copied).
void ParseKeyframeEntries(int section, std::span<const uint8_t> bytes, const MapCounts& c,
                          const RecordSizes& sizes, const uint8_t* table,
                          const std::shared_ptr<const void>& mapping,
                          std::vector<KeyFrameRecord>* keyframes) {
  const uint8_t* p = bytes.data();
  const uint8_t* indices = p + kFvGroupSize * c.feature_vector_groups;
  const uint8_t* loops = p + kConnectionSize * c.connections;
  for (size_t i = 0; i < keyframes->size(); ++i) {
    KeyFrameRecord& kf = (*keyframes)[i];
    const KeyframeCounts n = CountsOf(table + kKeyframeRecordSize * i);
    switch (section) {
      case kKeypoints:
        kf.keypoints = sizes.keypoint == sizeof(Keypoint)
                           ? EntriesAt<Keypoint>(&p, n.keypoints, mapping)
                           : KeypointsOfFormat1(&p, n.keypoints);
        break;
      case kDescriptors:
        kf.descriptors = EntriesAt<OrbDescriptor>(&p, n.keypoints, mapping);
        break;
      case kKfPoints:
        kf.map_point_ids = EntriesAt<uint64_t>(&p, n.keypoints, mapping);
        break;
      case kBow:
        ParsePairs(&p, n.bow, sizes.bow_entry, sizes.bow_entry - sizeof(double), &kf.bow);
        break;
      case kFeatureVectors:
        kf.feature_vector.resize(n.groups);
        for (auto& [node, list] : kf.feature_vector) {
          node = Load<uint32_t>(p);
          CopyEntries(&indices, Load<uint32_t>(p + 4), kFvIndexSize, &list);
          p += kFvGroupSize;
        }
        break;
      case kGraph:
        ParsePairs(&p, n.connections, kConnectionSize, 8, &kf.connections);
        CopyEntries(&loops, n.loops, kLoopEdgeSize, &kf.loop_edges);
        break;
    }
  }
}

// Parses the map point of record `r`, whose observations (records of
// `observation_size` bytes) start at `observations`; returns the end of its
// observations.
const uint8_t* ParseMapPoint(const uint8_t* r, const uint8_t* observations, size_t observation_size,
                             MapPointRecord* out) {
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
    mp.observations[k] = {Load<uint64_t>(observations + observation_size * k),
                          Load<uint32_t>(observations + observation_size * k + 8)};
  }
  return observations + observation_size * n;
}

// Every count checked against the size of its section, then the per-record
// counts against the totals, before anything is allocated: a corrupt count
// cannot cause a huge allocation.
void CheckCounts(const Sections& s, const MapCounts& c, const RecordSizes& sizes,
                 const std::string& source) {
  for (int i = kKeyframes; i < kNumSections; ++i) {
    const uint64_t expected = ExpectedSectionSize(i, c, sizes);
    if (s[i].size() != expected) {
      throw DataError(source + ": " + SectionText(i) + ": " + std::to_string(s[i].size()) +
                      " bytes, but the counts in section meta need " +
                      (expected == std::numeric_limits<uint64_t>::max()
                           ? std::string("more than 2^64")
                           : std::to_string(expected)) +
                      " (truncated or corrupt)");
    }
  }
  // Summed in 64 bits (each count is 32-bit).
  uint64_t sum[5] = {0, 0, 0, 0, 0};
  for (uint64_t i = 0; i < c.keyframes; ++i) {
    const KeyframeCounts n = CountsOf(s[kKeyframes].data() + kKeyframeRecordSize * i);
    const uint32_t each[5] = {n.keypoints, n.bow, n.groups, n.connections, n.loops};
    for (int k = 0; k < 5; ++k) sum[k] += each[k];
  }
  CheckTotal(sum[0], c.keypoints, "keypoints", "keyframes", source);
  CheckTotal(sum[1], c.bow_entries, "bow entries", "keyframes", source);
  CheckTotal(sum[2], c.feature_vector_groups, "feature vector groups", "keyframes", source);
  CheckTotal(sum[3], c.connections, "connections", "keyframes", source);
  CheckTotal(sum[4], c.loop_edges, "loop edges", "keyframes", source);
  uint64_t sum_indices = 0;
  for (uint64_t g = 0; g < c.feature_vector_groups; ++g) {
    sum_indices += Load<uint32_t>(s[kFeatureVectors].data() + kFvGroupSize * g + 4);
  }
  CheckTotal(sum_indices, c.feature_vector_indices, "feature vector indices", "feature_vectors",
             source);
  uint64_t sum_observations = 0;
  for (uint64_t i = 0; i < c.map_points; ++i) {
    sum_observations += Load<uint32_t>(s[kMapPoints].data() + kMapPointRecordSize * i + 128);
  }
  CheckTotal(sum_observations, c.observations, "observations", "map_points", source);
}

// Where the parsed bytes are: a mapped file (`file`; null for bytes in
// memory), prefaulted and released section by section, whose keypoints,
// descriptors and map point ids the records view in place.
struct MappedSource {
  std::shared_ptr<const MappedFile> file;

  // The keep-alive of the viewed arrays (null: they are copied).
  std::shared_ptr<const void> ViewedFile() const { return file; }
  bool Views(int section) const {
    return file != nullptr &&
           (section == kKeypoints || section == kDescriptors || section == kKfPoints);
  }
};

// The records, one section at a time; when `source` is a mapped file, each
// section it does not view is dropped from memory once parsed, so the
// records, the viewed sections and one more are resident at once. Every
// read stays within its section by CheckCounts.
void ParseRecords(const Sections& s, const MapCounts& c, const RecordSizes& sizes,
                  const MappedSource& source, MapData* map) {
  const auto prefault = [&](int i) {
    if (source.file != nullptr) source.file->Prefault(s[i]);
  };
  const auto release = [&](int i) {
    if (source.file != nullptr && !source.Views(i)) source.file->Release(s[i]);
  };
  const uint8_t* table = s[kKeyframes].data();
  prefault(kKeyframes);
  map->keyframes.resize(c.keyframes);
  for (uint64_t i = 0; i < c.keyframes; ++i) {
    ParseKeyframeRecord(table + kKeyframeRecordSize * i, &map->keyframes[i]);
  }
  for (const int i : {kKeypoints, kDescriptors, kKfPoints, kBow, kFeatureVectors, kGraph}) {
    prefault(i);
    ParseKeyframeEntries(i, s[i], c, sizes, table, source.ViewedFile(), &map->keyframes);
    release(i);
  }
  release(kKeyframes);
  prefault(kMapPoints);
  prefault(kObservations);
  const uint8_t* observations = s[kObservations].data();
  map->map_points.resize(c.map_points);
  for (uint64_t i = 0; i < c.map_points; ++i) {
    observations = ParseMapPoint(s[kMapPoints].data() + kMapPointRecordSize * i, observations,
                                 sizes.observation, &map->map_points[i]);
  }
  release(kMapPoints);
  release(kObservations);
}

// Drops the pages of every section that no record views (the checksum read
// them all).
void ReleaseCopiedSections(const std::vector<Sections>& parts, const MappedSource& source) {
  for (const Sections& s : parts) {
    for (int i = 0; i < kNumSections; ++i) {
      if (!source.Views(i)) source.file->Release(s[i]);
    }
  }
}

// One map's checked sections parsed (`where` names it in errors).
MapData ParsePart(const Sections& s, const RecordSizes& sizes, const std::string& where,
                  const MappedSource& mapping) {
  MapCounts c;
  MapData map = ParseMeta(s[kMeta], where, &c);
  CheckCounts(s, c, sizes, where);
  ParseRecords(s, c, sizes, mapping, &map);
  return map;
}

// `mapping.file`, when non-null, is the mapped file that `file` is.
MapData ParseAll(std::span<const uint8_t> file, const std::string& source, MapFileInfo* info,
                 const MappedSource& mapping) {
  const ParsedHeader h = ParseHeader(file, source);
  // The known sections of the map and of its other maps (since 1.1, while
  // "<k>:meta" is listed), and the payload's checksum over all of them.
  std::vector<Sections> parts = {FoundSections(h, source)};
  for (size_t k = 1; k <= kMaxOtherMaps && FindSection(h, kMeta, source, k) != nullptr; ++k) {
    parts.push_back(FoundSections(h, source, k));
  }
  // The checksum runs on a thread of its own while the records are parsed
  // and validated (parsing is safe on any bytes: every count is checked
  // against its section's size before anything is allocated or read, and
  // validation on any records; the fuzzer feeds both files with repaired
  // checksums); a corrupt payload is reported before any other error, as if
  // it had been checked first.
  std::future<bool> intact = std::async(std::launch::async, [&h] { return PayloadIntact(h); });
  MapData map;
  try {
    map = ParsePart(parts[0], h.sizes, source, mapping);
    for (size_t k = 1; k < parts.size(); ++k) {
      map.other_maps.push_back(
          ParsePart(parts[k], h.sizes, source + " (other map " + std::to_string(k) + ")", mapping));
    }
    ValidateMapData(map, source);
  } catch (const DataError&) {
    if (!intact.get()) ThrowCorruptPayload(h, parts.size(), source);
    throw;
  }
  if (!intact.get()) ThrowCorruptPayload(h, parts.size(), source);
  if (mapping.file != nullptr) ReleaseCopiedSections(parts, mapping);  // Read by the checksum too.
  if (info != nullptr) *info = h.info;
  return map;
}

}  // namespace

// ---------------------------------------------------------------------------
// Public functions

std::vector<uint8_t> EncodeMap(const MapData& map) {
  const MapLayout layout = LayOut(map);
  std::vector<uint8_t> file;
  file.reserve(layout.header_size + layout.payload_size);
  const EncodedHeader header =
      EncodeWith(layout, [&](uint64_t offset, std::span<const uint8_t> bytes) {
        file.resize(offset);  // The zeros of the header's place in the first piece.
        file.insert(file.end(), bytes.begin(), bytes.end());
      });
  std::memcpy(file.data(), header.bytes.data(), header.bytes.size());
  return file;
}

MapFileInfo WriteMapFileAt(const std::filesystem::path& file, const MapData& map,
                           const std::string& name) {
  const MapLayout layout = LayOut(map);
  FileSink sink(file, name);
  EncodedHeader header = EncodeWith(layout, [&](uint64_t offset, std::span<const uint8_t> bytes) {
    sink.WriteAt(offset, bytes);
  });
  sink.WriteAt(0, header.bytes);
  sink.Close();
  return std::move(header.info);
}

void WriteMapFile(const std::filesystem::path& path, const MapData& map) {
  AtomicOutput out(path);
  WriteMapFileAt(out.temp_path(), map, path.string());
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
  return ParseAll(file, source, info, {});
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
  const MappedSource mapping{std::make_shared<const MappedFile>(path, /*populate=*/true)};
  return ParseAll(mapping.file->bytes(), path.string(), info, mapping);
}

HeapReservation ReserveHeapForMap(const std::filesystem::path& path, double heap_factor,
                                  double prefault_factor) {
  std::error_code size_error;
  const uintmax_t file_bytes = std::filesystem::file_size(path, size_error);
  if (size_error) return HeapReservation(0, 0);
  const double bytes = static_cast<double>(file_bytes);
  return HeapReservation(static_cast<size_t>(heap_factor * bytes),
                         static_cast<size_t>(prefault_factor * bytes));
}

// ---------------------------------------------------------------------------
// Validation

namespace {

std::string KfText(uint64_t id) { return "keyframe " + std::to_string(id); }
std::string MpText(uint64_t id) { return "map point " + std::to_string(id); }
std::string IdText(uint64_t id) { return id == kNoId ? std::string("none") : std::to_string(id); }

// Id -> index lookups for validation, for sorted unique ids below `end`
// (checked before it is built; CheckMapNextIds bounds `end`): a bitmap of
// the ids and, with each 64 of its bits, the number of ids before them, so
// an id's index is that count plus the set bits below it in its word. One
// 16-byte read per lookup, from an array of end / 4 bytes (the 10k-keyframe
// map's 582 660 map points: 146 kB), where a hash table of the ids (32 MB
// there) cost a cache miss per keypoint.
class IdIndex {
 public:
  IdIndex(const std::vector<uint64_t>& ids, uint64_t end) : blocks_((end + 63) / 64) {
    for (const uint64_t id : ids) blocks_[id >> 6].bits |= uint64_t{1} << (id & 63);
    uint64_t before = 0;
    for (Block& b : blocks_) {
      b.before = before;
      before += static_cast<uint64_t>(std::popcount(b.bits));
    }
  }
  // Index of `id`, or -1.
  int64_t Find(uint64_t id) const {
    if (id / 64 >= blocks_.size()) return -1;
    const Block& b = blocks_[id >> 6];
    const uint64_t bit = uint64_t{1} << (id & 63);
    if ((b.bits & bit) == 0) return -1;
    return static_cast<int64_t>(b.before +
                                static_cast<uint64_t>(std::popcount(b.bits & (bit - 1))));
  }

 private:
  struct Block {
    uint64_t bits = 0;
    uint64_t before = 0;  // Ids below this block's.
  };
  std::vector<Block> blocks_;
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
    kf_index_ = IdIndex(kf_ids_, map_.next_keyframe_id);
    mp_index_ = IdIndex(mp_ids_, map_.next_map_point_id);
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
  IdIndex kf_index_{{}, 0}, mp_index_{{}, 0};
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
    const Keypoint& p = kf.keypoints[i];
    if (!(std::isfinite(p.pixel.x()) && std::isfinite(p.pixel.y()) &&
          std::isfinite(p.undistorted.x()) && std::isfinite(p.undistorted.y()) &&
          std::isfinite(p.angle_deg) && std::isfinite(p.response) && std::isfinite(p.depth))) {
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
  if (map.other_maps.size() > kMaxOtherMaps) {
    throw DataError(source + ": " + std::to_string(map.other_maps.size()) +
                    " other maps; at most " + std::to_string(kMaxOtherMaps));
  }
  for (size_t k = 0; k < map.other_maps.size(); ++k) {
    const MapData& other = map.other_maps[k];
    const std::string where = source + " (other map " + std::to_string(k + 1) + ")";
    if (!other.other_maps.empty()) throw DataError(where + ": has other maps of its own");
    if (!(other.camera == map.camera) || !other.vocabulary.SameTree(map.vocabulary) ||
        other.bow_levels_up != map.bow_levels_up) {
      throw DataError(where + ": another camera, vocabulary or BoW grouping than the map's");
    }
    MapValidator(other, where).Run();
  }
}

}  // namespace rrslam
