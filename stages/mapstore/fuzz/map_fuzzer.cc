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
#include <span>
#include <vector>

#include "common/binary_header.h"
#include "common/errors.h"
#include "common/formats.h"
#include "common/fuzz/check.h"
#include "common/fuzz/repair_header.h"
#include "stages/mapstore/map_file.h"

using rrslam::fuzz::Check;

namespace {

void Exercise(std::span<const uint8_t> bytes) {
  try {
    (void)rrslam::ReadMapFileInfo(bytes, "fuzz-input");
    (void)rrslam::ParseMapMeta(bytes, "fuzz-input");
  } catch (const rrslam::Error&) {
  }
  rrslam::MapData map;
  try {
    map = rrslam::ParseMap(bytes, "fuzz-input");
  } catch (const rrslam::Error&) {
    return;
  }
  // Outside the try: an error reading back what EncodeMap wrote is a finding.
  const std::vector<uint8_t> encoded = rrslam::EncodeMap(map);
  const rrslam::MapData again = rrslam::ParseMap(encoded, "re-encoded");
  Check(rrslam::EncodeMap(again) == encoded);
}

// Makes the header and every checksum of `file` consistent where its layout
// allows (common/fuzz/repair_header.h): the base header, and the XXH3 of each
// section table entry (uint32 count at offset 40, then 40-byte entries from
// offset 48 whose bytes 16, 24 and 32 are offset, size and checksum) that
// lies inside the payload. False when the header cannot be located.
bool Repair(std::vector<uint8_t>* file) {
  constexpr uint32_t kBase = rrslam::kBaseHeaderSize;
  return rrslam::fuzz::RepairBinaryHeader(
      file, rrslam::kMapFormat, kBase + 8,
      [](std::span<uint8_t> header, std::span<const uint8_t> payload) {
        const uint32_t count = rrslam::LoadLittleEndian<uint32_t>(header.data() + kBase);
        for (uint64_t i = 0; i < count && kBase + 8 + 40 * (i + 1) <= header.size(); ++i) {
          uint8_t* e = header.data() + kBase + 8 + 40 * i;
          const uint64_t offset = rrslam::LoadLittleEndian<uint64_t>(e + 16);
          const uint64_t size = rrslam::LoadLittleEndian<uint64_t>(e + 24);
          if (offset > payload.size() || size > payload.size() - offset) continue;
          rrslam::StoreLittleEndian<uint64_t>(e + 32,
                                              rrslam::Checksum64(payload.subspan(offset, size)));
        }
      });
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  Exercise({data, size});
  std::vector<uint8_t> repaired(data, data + size);
  if (Repair(&repaired)) Exercise(repaired);
  return 0;
}
