// Reading and writing rrslam.map files (format "rrslam.map" 1.0, magic
// "RRSLMAP1"), and the relation checks every loaded map passes.
//
// docs/mapstore.md describes the format byte by byte. In short: the common
// header of common/binary_header.h (magic, version, header size, XXH3 of the
// payload and of the header), then a table of sections, each with its own
// offset, size and XXH3-64, so a corrupt file names the section that broke.
//
// Thread-safety: functions are reentrant; no shared state.
#pragma once

#include <cstdint>
#include <filesystem>
#include <span>
#include <string>
#include <vector>

#include "common/heap_reserve.h"
#include "stages/mapstore/map_data.h"

namespace rrslam {

// One section of a map file as the header's table lists it.
struct MapSectionInfo {
  std::string name;       // "camera", "keyframes", "keypoints", ...
  uint64_t offset = 0;    // Bytes from the start of the payload.
  uint64_t size = 0;      // Bytes.
  uint64_t checksum = 0;  // XXH3-64 of the section's bytes.
};

struct MapFileInfo {
  uint16_t major = 0, minor = 0;
  uint64_t file_size = 0;
  std::vector<MapSectionInfo> sections;
};

// The whole file for `map` (deterministic: the same MapData gives the same
// bytes). Does not validate `map`; callers that build it from a live map do.
std::vector<uint8_t> EncodeMap(const MapData& map);

// Writes `map` to `path` atomically (AtomicOutput: name.tmp, fsync, rename).
// Throws CantCreateError naming the path. The bytes are EncodeMap's, encoded
// and written piece by piece (4 MB at a time, each piece's writeback started
// at once), never held whole in memory.
void WriteMapFile(const std::filesystem::path& path, const MapData& map);

// The same bytes written to `file` itself (created or truncated), for a
// caller that owns the AtomicOutput (its Commit fsyncs and renames); errors
// name `name`, the final path. Returns the header and section table, as
// ReadMapFileInfo would read them back.
MapFileInfo WriteMapFileAt(const std::filesystem::path& file, const MapData& map,
                           const std::string& name);

// Parses a whole file: header, the payload's checksum (and, when it fails,
// each section's, to name the corrupt one), the sections' bounds, the
// records, then ValidateMapData. Throws DataError naming `source` and the
// first problem ("map.rrm: section keypoints: checksum mismatch",
// "map.rrm: format major version 2, this build reads 1", ...). `info`, when
// non-null, receives the header and section table.
MapData ParseMap(std::span<const uint8_t> file, const std::string& source,
                 MapFileInfo* info = nullptr);

// Reads and parses `path`. The keyframes' keypoints, descriptors and map
// point ids (70% of a file) are not copied: they view the file's read-only
// mapping (RecordArray, record_array.h), which stays open until the last of
// them goes, so a reader can keep them (track keeps the descriptors in its
// keyframes). rrslam replaces map files by rename (AtomicOutput), never in
// place, so the mapped bytes stay as read; a program that truncates or
// rewrites the file in place while they live changes them under the reader
// (or ends it with SIGBUS). Throws NoInputError when it is missing or is a
// folder, DataError as ParseMap.
MapData ReadMapFile(const std::filesystem::path& path, MapFileInfo* info = nullptr);

// The calling thread's heap prepared for loading `path` (HeapReservation,
// common/heap_reserve.h): `heap_factor` times the file's size reserved in
// huge-page memory, the first `prefault_factor` times it made resident by a
// thread of its own ahead of the load's allocations (the records alone take
// about 1x): on a virtual machine the fresh pages' faults are most of a big
// map's load (docs/mapstore.md). Keep it while the load allocates; the load
// itself (ReadMapFile, then whatever builds on the records) runs on this
// thread. Nothing is reserved when the file's size cannot be read.
HeapReservation ReserveHeapForMap(const std::filesystem::path& path, double heap_factor,
                                  double prefault_factor);

// The header and section table only (checks the header, not the sections),
// for `rrslam-mapstore info` on a file whose sections may be corrupt.
MapFileInfo ReadMapFileInfo(std::span<const uint8_t> file, const std::string& source);

// Record counts as the "meta" section lists them.
struct MapCounts {
  uint64_t keyframes = 0;
  uint64_t map_points = 0;
  uint64_t keypoints = 0;    // All keyframes' keypoints.
  uint64_t bow_entries = 0;  // All keyframes' (word, value) entries.
  uint64_t feature_vector_groups = 0;
  uint64_t feature_vector_indices = 0;
  uint64_t connections = 0;  // Covisibility entries (each edge twice).
  uint64_t loop_edges = 0;   // Loop edge entries (each edge twice).
  uint64_t observations = 0;
};

// The "meta" section alone: camera, vocabulary, bow_levels_up, next ids and
// metadata of the map (no keyframes or map points), and its counts. Checks the
// header and the meta section's checksum only, for `rrslam-mapstore info` on a
// file whose other sections may be corrupt. Throws DataError as ParseMap.
MapData ParseMapMeta(std::span<const uint8_t> file, const std::string& source,
                     MapCounts* counts = nullptr);

// Throws DataError naming `source` and the field when a next id is above
// MaxNextMapId of its count (map_data.h): what loading the map (track) would
// allocate per id must stay in proportion to the map.
void CheckMapNextIds(const MapData& map, const std::string& source);

// Checks every relation listed in map_data.h, that the next ids are within
// CheckMapNextIds' bound, and that counts and values are
// sane (finite positions and poses, unit quaternions within 1e-6, octaves
// below the camera's ORB levels, parallel arrays of equal length, feature
// vector indices in range, word ids below the vocabulary's words). Throws
// DataError naming `source` and the first violation, with the ids involved.
void ValidateMapData(const MapData& map, const std::string& source);

}  // namespace rrslam
