#include "stages/mapstore/file_sink.h"

#include <gtest/gtest.h>

#include <fstream>
#include <iterator>
#include <numeric>
#include <vector>

#include "common/errors.h"
#include "common/testing.h"

namespace rrslam {
namespace {

using testing::TempDir;

std::vector<uint8_t> FileBytes(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::vector<uint8_t>((std::istreambuf_iterator<char>(in)), {});
}

// Aligned wholes (direct where the file system takes it), an unaligned tail,
// and a header written over the first block at the end: the file holds each
// piece's bytes at its offset, whichever way they went.
TEST(FileSink, PiecesLandAtTheirOffsets) {
  TempDir dir;
  constexpr size_t kBlock = FileSink::kAlignment;
  constexpr size_t kPiece = 16 * kBlock;
  const FileSink::Buffer buffer = FileSink::AlignedBuffer(kPiece + kBlock);
  std::vector<uint8_t> expected(3 * kPiece + 1000, 0);
  std::iota(expected.begin(), expected.end(), uint8_t{7});
  FileSink sink(dir / "out.bin", "out.bin");
  for (size_t k = 0; k < 3; ++k) {
    std::copy_n(expected.begin() + static_cast<ptrdiff_t>(k * kPiece), kPiece, buffer.get());
    sink.WriteAt(k * kPiece, {buffer.get(), kPiece});
  }
  // Unaligned size, then an unaligned address.
  sink.WriteAt(3 * kPiece, {expected.data() + 3 * kPiece, 1000});
  const std::vector<uint8_t> header = {1, 2, 3, 4, 5};
  std::copy(header.begin(), header.end(), buffer.get() + 1);
  sink.WriteAt(0, {buffer.get() + 1, header.size()});
  std::copy(header.begin(), header.end(), expected.begin());
  sink.Close();
  EXPECT_EQ(FileBytes(dir / "out.bin"), expected);
}

TEST(FileSink, MissingFolderIsCantCreate) {
  TempDir dir;
  try {
    FileSink sink(dir / "missing" / "out.bin", "out.bin");
    FAIL() << "no error";
  } catch (const CantCreateError& e) {
    EXPECT_NE(std::string(e.what()).find("out.bin: cannot create"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace rrslam
