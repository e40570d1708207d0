#include "stages/eval/plot.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <functional>
#include <opencv2/imgcodecs.hpp>

#include "common/atomic_file.h"
#include "common/errors.h"
#include "common/geometry.h"
#include "common/testing.h"

namespace rrslam {
namespace {

// A loop in the x-z plane (y nearly constant), as a camera carried at eye height.
Trajectory MakeGroundTruth(int n) {
  Trajectory gt;
  for (int i = 0; i < n; ++i) {
    const double a = 2 * M_PI * i / n;
    StampedPose pose;
    pose.timestamp = 100 + i / 30.0;
    pose.T_world_cam.translation =
        Eigen::Vector3d(2 * std::cos(a), 0.05 * std::sin(3 * a), std::sin(a));
    gt.push_back(pose);
  }
  return gt;
}

AteResult MakeResult(const Trajectory& gt) {
  Trajectory est = gt;
  for (size_t i = 0; i < est.size(); ++i) {
    est[i].T_world_cam.translation += Eigen::Vector3d(0.05 * std::sin(0.1 * i), 0, 0.04);
  }
  est.erase(est.begin() + 40, est.begin() + 60);  // Lost tracking: a gap.
  return ComputeAte(gt, est);
}

// Bitwise CRC-32 (reflected polynomial 0xEDB88320), independent of the table
// version in plot.cc.
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

int CountPixels(const cv::Mat& image, const std::function<bool(const cv::Vec3b&)>& test) {
  int count = 0;
  for (int r = 0; r < image.rows; ++r) {
    for (int c = 0; c < image.cols; ++c) count += test(image.at<cv::Vec3b>(r, c)) ? 1 : 0;
  }
  return count;
}

TEST(ChoosePlotAxes, PicksTheTwoAxesOfLargestExtent) {
  const Trajectory gt = MakeGroundTruth(100);
  EXPECT_EQ(ChoosePlotAxes(gt, PlotAxes::kAuto), std::make_pair(0, 2));
  Trajectory yz = gt;
  for (StampedPose& p : yz) {
    const Eigen::Vector3d t = p.T_world_cam.translation;
    p.T_world_cam.translation = Eigen::Vector3d(t.y(), t.x(), t.z());
  }
  EXPECT_EQ(ChoosePlotAxes(yz, PlotAxes::kAuto), std::make_pair(1, 2));
  EXPECT_EQ(ChoosePlotAxes(gt, PlotAxes::kXY), std::make_pair(0, 1));
  EXPECT_EQ(ChoosePlotAxes(gt, PlotAxes::kYZ), std::make_pair(1, 2));
  EXPECT_EQ(ChoosePlotAxes(gt, PlotAxes::kXZ), std::make_pair(0, 2));
}

TEST(RenderAtePlot, DrawsTrajectoriesErrorsAndFrameAtTheRequestedSize) {
  const Trajectory gt = MakeGroundTruth(200);
  const AteResult result = MakeResult(gt);
  PlotOptions options;
  options.width_px = 900;
  options.height_px = 700;
  const cv::Mat image = RenderAtePlot(gt, result, options);
  ASSERT_EQ(image.type(), CV_8UC3);
  EXPECT_EQ(image.cols, 900);
  EXPECT_EQ(image.rows, 700);
  // Dark ground truth, blue estimate, red differences are all present.
  const int dark =
      CountPixels(image, [](const cv::Vec3b& p) { return p[0] < 60 && p[1] < 60 && p[2] < 60; });
  const int blue = CountPixels(image, [](const cv::Vec3b& p) { return p[0] > 150 && p[2] < 80; });
  const int red =
      CountPixels(image, [](const cv::Vec3b& p) { return p[2] > 180 && p[0] < 140 && p[1] < 140; });
  EXPECT_GT(dark, 1000);
  EXPECT_GT(blue, 1000);
  EXPECT_GT(red, 50);
  // The corners stay background (margins).
  EXPECT_EQ(image.at<cv::Vec3b>(0, 0), cv::Vec3b(255, 255, 255));
  EXPECT_EQ(image.at<cv::Vec3b>(699, 899), cv::Vec3b(255, 255, 255));
}

TEST(RenderAtePlot, RejectsInvalidSize) {
  const Trajectory gt = MakeGroundTruth(50);
  PlotOptions options;
  options.width_px = 100;
  EXPECT_THROW(RenderAtePlot(gt, MakeResult(gt), options), UsageError);
  std::string why;
  EXPECT_FALSE(options.Check(&why));
  EXPECT_NE(why.find("width"), std::string::npos);
  options = PlotOptions{};
  options.height_px = 9000;
  EXPECT_FALSE(options.Check(&why));
  EXPECT_NE(why.find("height"), std::string::npos);
  EXPECT_TRUE(PlotOptions{}.Check(&why));
}

TEST(EncodePng, StoresTextChunksWithValidChecksums) {
  cv::Mat image(60, 80, CV_8UC3, cv::Scalar(10, 20, 30));
  const std::vector<unsigned char> png =
      EncodePng(image, {{"Software", "rrslam-eval test"}, {"Comment", "{\"a\": 1}"}});
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

TEST(PlotAte, WritesAReadablePngAtomically) {
  testing::TempDir dir;
  const Trajectory gt = MakeGroundTruth(120);
  const AteResult result = MakeResult(gt);
  PlotAte(dir / "ate.png", gt, result);
  const cv::Mat read = cv::imread((dir / "ate.png").string(), cv::IMREAD_COLOR);
  ASSERT_FALSE(read.empty());
  EXPECT_EQ(read.cols, PlotOptions{}.width_px);
  EXPECT_EQ(read.rows, PlotOptions{}.height_px);
  EXPECT_FALSE(std::filesystem::exists(dir / "ate.png.tmp"));
  EXPECT_THROW(PlotAte(dir / "missing" / "ate.png", gt, result), CantCreateError);
  EXPECT_FALSE(std::filesystem::exists(dir / "missing"));
}

}  // namespace
}  // namespace rrslam
