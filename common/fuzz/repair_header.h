// Fuzz-only: makes the common header of an rrslam binary file consistent, so
// that a fuzzer's mutations get past the checksums to the checks behind them.
//
// A mutated file almost never carries a valid XXH3 of its header and payload
// (common/binary_header.h), so a fuzzer that only feeds its inputs as they are
// exercises the checksum comparison and little else: libFuzzer's coverage of
// the binary vocabulary loader stayed flat over 14 million runs (issue 16).
// The fuzzers of the binary formats (stages/vocab/fuzz, stages/mapstore/fuzz)
// therefore run each input twice: as it is, which keeps the header and
// checksum checks fuzzed, and once more after RepairBinaryHeader, which writes
// the magic, the major version, the payload size and both checksums (and,
// through `repair_fields`, a format's own checksums) as a writer would.
//
// Why a repair and not a build flag that skips the checksum checks in the
// readers: the fuzzers then run exactly the reader code that ships (no
// #ifdef'd branch in ParseBinaryHeader that the fuzz build compiles
// differently and could hide a bug), every crashing input is a valid file
// that reproduces with the released tools (rrslam-vocab info, rrslam-mapstore
// verify), and the checksum checks themselves stay fuzzed by the first pass.
// The cost is one XXH3 pass over the input per run, small next to parsing.
//
// Header-only, used only by fuzz targets; not part of any library.
#pragma once

#include <cstdint>
#include <cstring>
#include <functional>
#include <span>
#include <vector>

#include "common/binary_header.h"
#include "common/formats.h"

namespace rrslam::fuzz {

// Repairs format-specific fields of the header (e.g. the per-section
// checksums of rrslam.map) given the header bytes [0, header_size) and the
// payload. Called after the base fields are set and before the payload and
// header checksums are computed; it may write only into `header`.
using RepairHeaderFields =
    std::function<void(std::span<uint8_t> header, std::span<const uint8_t> payload)>;

// Makes the base header of `file` (layout in common/binary_header.h)
// consistent for `spec`: magic, major version, payload_size = bytes after
// header_size, then `repair_fields`, then the payload checksum and the header
// checksum. The minor version and header_size are left as they are, so their
// checks stay fuzzed. Returns false, leaving the file unusable for a repaired
// run, when the file is shorter than `min_header_size` or its header_size is
// not in [min_header_size, file size]; min_header_size must be at least
// kBaseHeaderSize.
inline bool RepairBinaryHeader(std::vector<uint8_t>* file, const FormatSpec& spec,
                               uint32_t min_header_size = kBaseHeaderSize,
                               const RepairHeaderFields& repair_fields = {}) {
  if (min_header_size < kBaseHeaderSize || file->size() < min_header_size) return false;
  uint8_t* p = file->data();
  std::memcpy(p, spec.magic, 8);
  StoreLittleEndian<uint16_t>(p + 8, spec.major);
  const uint32_t header_size = LoadLittleEndian<uint32_t>(p + 12);
  if (header_size < min_header_size || header_size > file->size()) return false;
  const std::span<const uint8_t> payload(p + header_size, file->size() - header_size);
  StoreLittleEndian<uint64_t>(p + 16, payload.size());
  if (repair_fields) repair_fields({p, header_size}, payload);
  StoreLittleEndian<uint64_t>(p + 24, Checksum64(payload));
  StoreLittleEndian<uint64_t>(p + 32, 0);
  StoreLittleEndian<uint64_t>(p + 32, Checksum64({p, header_size}));
  return true;
}

}  // namespace rrslam::fuzz
