// libFuzzer target: the map reader (rrslam.map, ParseMap).
//
// Each input is parsed twice: as it is, and with its magic, major version,
// payload size and every checksum repaired, so that mutations reach the
// section parsers and ValidateMapData instead of stopping at a checksum. Any
// rrslam::Error is an accepted rejection; anything else (a crash, a sanitizer
// report, another exception) is a finding. A map that parses must re-encode
// to bytes that parse to a map encoding to the same bytes.
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <span>
#include <vector>

#include "common/binary_header.h"
#include "common/errors.h"
#include "common/formats.h"
#include "stages/mapstore/map_file.h"

namespace {

void Check(bool condition) {
  if (!condition) std::abort();
}

void Exercise(std::span<const uint8_t> bytes) {
  try {
    (void)rrslam::ReadMapFileInfo(bytes, "fuzz-input");
    (void)rrslam::ParseMapMeta(bytes, "fuzz-input");
  } catch (const rrslam::Error&) {
  }
  try {
    const rrslam::MapData map = rrslam::ParseMap(bytes, "fuzz-input");
    const std::vector<uint8_t> encoded = rrslam::EncodeMap(map);
    const rrslam::MapData again = rrslam::ParseMap(encoded, "re-encoded");  // Must not throw.
    Check(rrslam::EncodeMap(again) == encoded);
  } catch (const rrslam::Error&) {
  }
}

// Makes the header and checksums of `file` consistent, where its layout
// allows; false when the header or table cannot be located.
bool Repair(std::vector<uint8_t>* file) {
  constexpr size_t kBase = rrslam::kBaseHeaderSize;
  if (file->size() < kBase + 8) return false;
  uint8_t* p = file->data();
  std::memcpy(p, rrslam::kMapFormat.magic, 8);
  rrslam::StoreLittleEndian<uint16_t>(p + 8, rrslam::kMapFormat.major);
  const uint32_t header_size = rrslam::LoadLittleEndian<uint32_t>(p + 12);
  if (header_size < kBase + 8 || header_size > file->size()) return false;
  const uint64_t payload_size = file->size() - header_size;
  rrslam::StoreLittleEndian<uint64_t>(p + 16, payload_size);
  uint8_t* payload = p + header_size;
  const uint32_t count = rrslam::LoadLittleEndian<uint32_t>(p + kBase);
  for (uint64_t i = 0; i < count && kBase + 8 + 40 * (i + 1) <= header_size; ++i) {
    uint8_t* e = p + kBase + 8 + 40 * i;
    const uint64_t offset = rrslam::LoadLittleEndian<uint64_t>(e + 16);
    const uint64_t size = rrslam::LoadLittleEndian<uint64_t>(e + 24);
    if (offset > payload_size || size > payload_size - offset) continue;
    rrslam::StoreLittleEndian<uint64_t>(e + 32, rrslam::Checksum64({payload + offset, size}));
  }
  rrslam::StoreLittleEndian<uint64_t>(p + 24, rrslam::Checksum64({payload, payload_size}));
  rrslam::StoreLittleEndian<uint64_t>(p + 32, 0);
  rrslam::StoreLittleEndian<uint64_t>(p + 32, rrslam::Checksum64({p, header_size}));
  return true;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  Exercise({data, size});
  std::vector<uint8_t> repaired(data, data + size);
  if (Repair(&repaired)) Exercise(repaired);
  return 0;
}
