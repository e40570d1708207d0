#include "common/image_io.h"

#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <random>

#include "common/atomic_file.h"
#include "common/errors.h"
#include "common/testing.h"

namespace rrslam {
namespace {

cv::Mat RandomImage(int type, uint32_t seed) {
  cv::Mat image(37, 53, type);
  cv::RNG rng(seed);
  rng.fill(image, cv::RNG::UNIFORM, 0, type == CV_16UC1 ? 65536 : 256);
  return image;
}

// Bitwise CRC-32 (reflected polynomial 0xEDB88320), independent of libpng's.
uint32_t BitwiseCrc32(const unsigned char* data, size_t size) {
  uint32_t crc = 0xFFFFFFFFu;
  for (size_t k = 0; k < size; ++k) {
    crc ^= data[k];
    for (int bit = 0; bit < 8; ++bit) crc = (crc >> 1) ^ (0xEDB88320u & (0u - (crc & 1u)));
  }
  return ~crc;
}

uint32_t BigEndian(const unsigned char* p) {
  return (uint32_t(p[0]) << 24) | (uint32_t(p[1]) << 16) | (uint32_t(p[2]) << 8) | p[3];
}

bool Equal(const cv::Mat& a, const cv::Mat& b) {
  return a.type() == b.type() && a.size() == b.size() && cv::norm(a, b, cv::NORM_INF) == 0;
}

TEST(ImageIo, PngRoundTripEveryType) {
  for (int type : {CV_8UC1, CV_8UC3, CV_8UC4, CV_16UC1}) {
    const cv::Mat image = RandomImage(type, 7);
    const std::vector<uint8_t> png = EncodePng(image);
    EXPECT_TRUE(Equal(DecodeImage(png, ImageReadMode::kUnchanged, "t.png"), image)) << type;
    // OpenCV's decoder agrees on channel order and 16-bit byte order.
    EXPECT_TRUE(Equal(cv::imdecode(png, cv::IMREAD_UNCHANGED), image)) << type;
  }
}

TEST(ImageIo, DecodesOpenCvWrittenFiles) {
  testing::TempDir dir;
  const cv::Mat color = RandomImage(CV_8UC3, 1), depth = RandomImage(CV_16UC1, 2);
  cv::imwrite((dir / "c.png").string(), color);
  cv::imwrite((dir / "d.png").string(), depth);
  EXPECT_TRUE(Equal(ReadImage(dir / "c.png", ImageReadMode::kColor), color));
  EXPECT_TRUE(Equal(ReadImage(dir / "d.png"), depth));
  cv::Mat gray_expected;
  cv::cvtColor(color, gray_expected, cv::COLOR_BGR2GRAY);
  EXPECT_TRUE(Equal(ReadImage(dir / "c.png", ImageReadMode::kGray), gray_expected));
}

TEST(ImageIo, JpegMatchesOpenCv) {
  testing::TempDir dir;
  cv::Mat smooth(48, 64, CV_8UC3);
  for (int y = 0; y < smooth.rows; ++y)
    for (int x = 0; x < smooth.cols; ++x) smooth.at<cv::Vec3b>(y, x) = cv::Vec3b(x * 3, y * 4, 128);
  cv::imwrite((dir / "c.jpg").string(), smooth);
  EXPECT_TRUE(Equal(ReadImage(dir / "c.jpg", ImageReadMode::kColor),
                    cv::imread((dir / "c.jpg").string(), cv::IMREAD_COLOR)));
  EXPECT_TRUE(Equal(ReadImage(dir / "c.jpg", ImageReadMode::kGray),
                    cv::imread((dir / "c.jpg").string(), cv::IMREAD_GRAYSCALE)));
}

TEST(ImageIo, SameInputSameBytesAndTextChunks) {
  const cv::Mat image = RandomImage(CV_8UC3, 3);
  const auto a = EncodePng(image, 6, {{"Software", "rrslam-test"}});
  const auto b = EncodePng(image, 6, {{"Software", "rrslam-test"}});
  EXPECT_EQ(a, b);
  const std::string bytes(a.begin(), a.end());
  EXPECT_NE(bytes.find("tEXtSoftware"), std::string::npos);
}

TEST(ImageIo, RejectsCorruptTruncatedAndWrongModes) {
  testing::TempDir dir;
  EXPECT_THROW(ReadImage(dir / "absent.png"), NoInputError);
  testing::WriteTextFile(dir / "text.png", "hello");
  EXPECT_THROW(ReadImage(dir / "text.png"), DataError);
  const auto png = EncodePng(RandomImage(CV_8UC3, 4));
  EXPECT_THROW(DecodeImage(std::span(png).first(png.size() / 2), ImageReadMode::kUnchanged, "t"),
               DataError);
  std::vector<uint8_t> corrupt = png;
  corrupt[40] ^= 0xff;  // Inside IHDR/IDAT: CRC or zlib failure.
  EXPECT_THROW(DecodeImage(corrupt, ImageReadMode::kUnchanged, "t"), DataError);
  const auto depth = EncodePng(RandomImage(CV_16UC1, 5));
  EXPECT_THROW(DecodeImage(depth, ImageReadMode::kGray, "d.png"), DataError);
  std::string jpeg = "\xff\xd8\xff\xe0 truncated";
  EXPECT_THROW(DecodeImage(std::span(reinterpret_cast<const uint8_t*>(jpeg.data()), jpeg.size()),
                           ImageReadMode::kColor, "t.jpg"),
               DataError);
}

TEST(ImageIo, StoresTextChunksWithValidChecksums) {
  cv::Mat image(60, 80, CV_8UC3, cv::Scalar(10, 20, 30));
  const std::vector<uint8_t> png =
      EncodePng(image, 6, {{"Software", "rrslam-eval test"}, {"Comment", "{\"a\": 1}"}});
  // The image decodes unchanged.
  const cv::Mat decoded = cv::imdecode(png, cv::IMREAD_UNCHANGED);
  ASSERT_FALSE(decoded.empty());
  EXPECT_EQ(cv::norm(decoded, image, cv::NORM_INF), 0);
  // Walk the chunks: every CRC is right, and both text chunks are there.
  ASSERT_GT(png.size(), 8u);
  EXPECT_EQ(std::string(png.begin() + 1, png.begin() + 4), "PNG");
  std::vector<std::string> texts;
  size_t pos = 8;
  std::string last_type;
  while (pos + 12 <= png.size()) {
    const uint32_t length = BigEndian(&png[pos]);
    const std::string type(png.begin() + pos + 4, png.begin() + pos + 8);
    ASSERT_LE(pos + 12 + length, png.size());
    EXPECT_EQ(BigEndian(&png[pos + 8 + length]), BitwiseCrc32(&png[pos + 4], 4 + length)) << type;
    if (type == "tEXt") texts.emplace_back(png.begin() + pos + 8, png.begin() + pos + 8 + length);
    last_type = type;
    pos += 12 + length;
  }
  EXPECT_EQ(pos, png.size());
  EXPECT_EQ(last_type, "IEND");
  ASSERT_EQ(texts.size(), 2u);
  EXPECT_EQ(texts[0], std::string("Software\0rrslam-eval test", 25));
  EXPECT_EQ(texts[1], std::string("Comment\0{\"a\": 1}", 16));
}

void StoreBigEndian(unsigned char* p, uint32_t value) {
  for (int i = 0; i < 4; ++i) p[i] = static_cast<unsigned char>(value >> (24 - 8 * i));
}

// A small PNG whose IHDR (the first chunk) declares width x height, with a
// valid CRC: a decompression bomb of a few hundred bytes.
std::vector<uint8_t> PngDeclaring(uint32_t width, uint32_t height) {
  std::vector<uint8_t> png = EncodePng(RandomImage(CV_8UC3, 8));
  EXPECT_EQ(std::string(png.begin() + 12, png.begin() + 16), "IHDR");
  StoreBigEndian(&png[16], width);
  StoreBigEndian(&png[20], height);
  StoreBigEndian(&png[29], BitwiseCrc32(&png[12], 4 + 13));
  return png;
}

// A small JPEG whose frame header (SOF0) declares width x height.
std::vector<uint8_t> JpegDeclaring(uint16_t width, uint16_t height) {
  std::vector<uint8_t> jpeg;
  cv::imencode(".jpg", RandomImage(CV_8UC3, 9), jpeg);
  for (size_t i = 2; i + 9 < jpeg.size(); ++i) {
    if (jpeg[i] == 0xff && jpeg[i + 1] == 0xc0) {  // SOF0: length, precision, height, width.
      jpeg[i + 5] = static_cast<uint8_t>(height >> 8);
      jpeg[i + 6] = static_cast<uint8_t>(height);
      jpeg[i + 7] = static_cast<uint8_t>(width >> 8);
      jpeg[i + 8] = static_cast<uint8_t>(width);
      return jpeg;
    }
  }
  ADD_FAILURE() << "no SOF0 marker";
  return jpeg;
}

std::string DecodeError(std::span<const uint8_t> bytes, const ImageSizeLimit& limit = {}) {
  try {
    DecodeImage(bytes, ImageReadMode::kUnchanged, "bomb.png", limit);
  } catch (const DataError& e) {
    return e.what();
  }
  return "no error";
}

// A header declaring 65535 x 65535 pixels (34 GB decoded for a 16-bit RGBA
// PNG, from a file of a few hundred bytes) is refused from the header, naming
// the file and both sizes, before anything is allocated for the pixels.
TEST(ImageIo, RefusesImagesLargerThanTheCapFromTheHeader) {
  const std::vector<uint8_t> png = PngDeclaring(65535, 65535);
  ASSERT_LT(png.size(), 20000u);
  const bool measured = testing::ResetPeakResident();
  const long before = testing::PeakResidentKb();
  EXPECT_EQ(DecodeError(png),
            "bomb.png: image is 65535x65535, larger than 16384x16384 (the largest image read: "
            "16384 pixels a side)");
  EXPECT_EQ(DecodeError(PngDeclaring(kMaxImageSide + 1, 10)),
            "bomb.png: image is 16385x10, larger than 16384x16384 (the largest image read: "
            "16384 pixels a side)");
  EXPECT_EQ(DecodeError(JpegDeclaring(65000, 64000)),
            "bomb.png: image is 65000x64000, larger than 16384x16384 (the largest image read: "
            "16384 pixels a side)");
  // A limit above the cap does not lift it.
  EXPECT_NE(DecodeError(png, {100000, 100000, "s.yaml"}).find("larger than 16384x16384"),
            std::string::npos);
  if (measured) {
    EXPECT_LT(testing::PeakResidentKb() - before, 64 * 1024) << "kB";
  }
  // As a file, through the tool's path: DataError (exit 65).
  testing::TempDir dir;
  WriteFileAtomically(dir / "bomb.png", std::string(png.begin(), png.end()));
  EXPECT_THROW(ReadImage(dir / "bomb.png", ImageReadMode::kGray), DataError);
}

// With the settings' Camera.width x Camera.height, a larger image is refused
// (it would be used with the wrong calibration); that size or smaller reads.
TEST(ImageIo, RefusesImagesLargerThanTheGivenSize) {
  const cv::Mat image = RandomImage(CV_8UC3, 10);  // 53 x 37.
  const std::vector<uint8_t> png = EncodePng(image);
  std::vector<uint8_t> jpeg;
  cv::imencode(".jpg", image, jpeg);
  const ImageSizeLimit narrow{52, 37, "Camera.width x Camera.height of s.yaml"};
  EXPECT_EQ(DecodeError(png, narrow),
            "bomb.png: image is 53x37, larger than 52x37 (Camera.width x Camera.height of s.yaml)");
  EXPECT_EQ(DecodeError(jpeg, {53, 36, ""}), "bomb.png: image is 53x37, larger than 53x36");
  for (const ImageSizeLimit& fits :
       {ImageSizeLimit{53, 37, "s"}, ImageSizeLimit{640, 480, "s"}, ImageSizeLimit{}}) {
    EXPECT_TRUE(Equal(DecodeImage(png, ImageReadMode::kUnchanged, "t.png", fits), image));
    EXPECT_EQ(DecodeImage(jpeg, ImageReadMode::kColor, "t.jpg", fits).size(), image.size());
  }
}

TEST(ImageIo, WritePngIsAtomic) {
  testing::TempDir dir;
  WritePng(dir / "a.png", RandomImage(CV_8UC1, 6));
  EXPECT_TRUE(std::filesystem::exists(dir / "a.png"));
  EXPECT_EQ(testing::TemporaryLeftovers(dir), std::vector<std::string>{});
  EXPECT_THROW(WritePng(dir / "missing" / "a.png", RandomImage(CV_8UC1, 6)), CantCreateError);
}

}  // namespace
}  // namespace rrslam
