#include "common/binary_header.h"

#include <gtest/gtest.h>

#include <cstring>

#include "common/errors.h"
#include "common/testing.h"

namespace rrslam {
namespace {

constexpr FormatSpec kTestFormat = {"rrslam.test", "RRSLTEST", 2, 3};

std::vector<uint8_t> MakeFile(const FormatSpec& spec, const std::string& payload_text) {
  const std::vector<uint8_t> fields = {1, 2, 3, 4, 5};
  const std::vector<uint8_t> payload(payload_text.begin(), payload_text.end());
  std::vector<uint8_t> file = BuildBinaryHeader(spec, fields, payload);
  file.insert(file.end(), payload.begin(), payload.end());
  return file;
}

TEST(BinaryHeader, RoundTrip) {
  const std::vector<uint8_t> file = MakeFile(kTestFormat, "payload bytes");
  const BinaryHeaderView view = ParseBinaryHeader(file, kTestFormat, "t.bin");
  EXPECT_EQ(view.major, 2);
  EXPECT_EQ(view.minor, 3);
  ASSERT_EQ(view.fields.size(), 8u);  // Padded to a multiple of 8.
  EXPECT_EQ(view.fields[4], 5);
  EXPECT_EQ(view.fields[5], 0);
  EXPECT_EQ(std::string(view.payload.begin(), view.payload.end()), "payload bytes");
  EXPECT_NO_THROW(VerifyPayloadChecksum(view, "t.bin"));
}

// A file's checksum is its content's, over the 1 MiB pieces it is read in;
// what is not a readable file is a NoInputError.
TEST(FileChecksum64, IsTheContentsChecksum) {
  testing::TempDir dir;
  std::string text((size_t{3} << 20) + 5, '\0');
  for (size_t i = 0; i < text.size(); ++i) text[i] = static_cast<char>(i * 131 + 7);
  testing::WriteTextFile(dir / "big.bin", text);
  testing::WriteTextFile(dir / "empty.bin", "");
  const auto bytes = [](const std::string& t) {
    return std::span<const uint8_t>(reinterpret_cast<const uint8_t*>(t.data()), t.size());
  };
  EXPECT_EQ(FileChecksum64(dir / "big.bin"), Checksum64(bytes(text)));
  EXPECT_EQ(FileChecksum64(dir / "empty.bin"), Checksum64({}));
  EXPECT_THROW(FileChecksum64(dir / "absent.bin"), NoInputError);
  EXPECT_THROW(FileChecksum64(dir.path()), NoInputError);
}

TEST(StreamingChecksum64, PiecesGiveTheWholeChecksum) {
  std::vector<uint8_t> bytes(10000);
  for (size_t i = 0; i < bytes.size(); ++i) bytes[i] = static_cast<uint8_t>(i * 131 + 7);
  StreamingChecksum64 pieces;
  size_t at = 0;
  for (size_t n : {0, 1, 63, 64, 1000, 5000}) {  // Across XXH3's internal block sizes.
    pieces.Update({bytes.data() + at, n});
    at += n;
  }
  pieces.Update({bytes.data() + at, bytes.size() - at});
  EXPECT_EQ(pieces.Digest(), Checksum64(bytes));
  StreamingChecksum64 moved = std::move(pieces);
  EXPECT_EQ(moved.Digest(), Checksum64(bytes));
  EXPECT_EQ(StreamingChecksum64().Digest(), Checksum64({}));
}

TEST(BinaryHeader, HeaderForAStreamedPayloadIsTheSame) {
  const std::vector<uint8_t> fields = {9, 8, 7};
  const std::vector<uint8_t> payload = {1, 2, 3, 4, 5, 6, 7, 8};
  EXPECT_EQ(BuildBinaryHeader(kTestFormat, fields, payload.size(), Checksum64(payload)),
            BuildBinaryHeader(kTestFormat, fields, payload));
}

TEST(BinaryHeader, AcceptsNewerMinor) {
  FormatSpec newer = kTestFormat;
  newer.minor = 9;
  const std::vector<uint8_t> file = MakeFile(newer, "x");
  EXPECT_EQ(ParseBinaryHeader(file, kTestFormat, "t.bin").minor, 9);
}

void ExpectRejected(const std::vector<uint8_t>& file, const std::string& fragment) {
  try {
    const BinaryHeaderView view = ParseBinaryHeader(file, kTestFormat, "t.bin");
    VerifyPayloadChecksum(view, "t.bin");
    FAIL() << "accepted; expected error containing '" << fragment << "'";
  } catch (const DataError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("t.bin"), std::string::npos) << what;
    EXPECT_NE(what.find(fragment), std::string::npos) << what;
  }
}

TEST(BinaryHeader, RejectsTruncation) {
  const std::vector<uint8_t> file = MakeFile(kTestFormat, "some payload");
  for (size_t size : {size_t(0), size_t(7), size_t(39), size_t(47), file.size() - 1}) {
    ExpectRejected(std::vector<uint8_t>(file.begin(), file.begin() + size), "runcated");
  }
}

TEST(BinaryHeader, RejectsBadMagic) {
  std::vector<uint8_t> file = MakeFile(kTestFormat, "p");
  file[0] = 'X';
  ExpectRejected(file, "bad magic");
}

TEST(BinaryHeader, RejectsFutureMajor) {
  FormatSpec future = kTestFormat;
  future.major = 3;
  ExpectRejected(MakeFile(future, "p"), "version 3.3 is not supported");
}

TEST(BinaryHeader, RejectsCorruptHeaderAndPayload) {
  std::vector<uint8_t> file = MakeFile(kTestFormat, "payload");
  std::vector<uint8_t> header_flip = file;
  header_flip[41] ^= 0x10;  // A format-specific field.
  ExpectRejected(header_flip, "header checksum");
  std::vector<uint8_t> payload_flip = file;
  payload_flip.back() ^= 0x01;
  ExpectRejected(payload_flip, "checksum mismatch");
  std::vector<uint8_t> padded = file;
  padded.push_back(0);
  ExpectRejected(padded, "padded");
}

TEST(MappedFile, MapsWholeFileAndRejectsMissing) {
  testing::TempDir dir;
  testing::WriteTextFile(dir / "f.bin", "0123456789");
  MappedFile mapped(dir / "f.bin", true);
  ASSERT_EQ(mapped.bytes().size(), 10u);
  EXPECT_EQ(mapped.bytes()[3], '3');
  MappedFile moved = std::move(mapped);
  EXPECT_EQ(moved.bytes().size(), 10u);
  EXPECT_EQ(mapped.bytes().size(), 0u);
  EXPECT_THROW(MappedFile(dir / "absent"), NoInputError);
  testing::WriteTextFile(dir / "empty", "");
  EXPECT_EQ(MappedFile(dir / "empty").bytes().size(), 0u);
}

}  // namespace
}  // namespace rrslam
